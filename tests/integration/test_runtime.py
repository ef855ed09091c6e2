"""The simulation as separate processes on a real Zenoh router."""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
import time
from pathlib import Path

import msgspec
import pytest

from iw_zenoh import keys
from iw_zenoh.messages import (
    ActionBatch,
    Actions,
    Event,
    RobotSpecMsg,
    SensorBatch,
    SensorReading,
    WorldState,
    decode,
    encode,
)
from iw_zenoh.record.tools import check
from tests.integration.harness import (
    MAPS,
    Net,
    iwz_run_argv,
    register,
    state_of,
    stop_run,
    subscribe,
    wait_alive,
    wait_event,
    wait_msg,
    watch,
)

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(120)]

LAB = """<Lab Name="test" Width="20" Height="10">
  <Wall Height="2"><Corner X="9" Y="0"/><Corner X="10" Y="0"/><Corner X="10" Y="3"/><Corner X="9" Y="3"/></Wall>
</Lab>"""
GRID = (
    """<Grid><Position X="2" Y="5" Dir="0"/><Position X="5" Y="5" Dir="0"/><Position X="8" Y="8" Dir="180"/></Grid>"""
)


RUN_TICKS = 30  # the ticks of a --duration 3 run: 3 s of 100 ms ticks


def _maps(tmp: Path) -> tuple[str, str]:
    (tmp / "lab.xml").write_text(LAB)
    (tmp / "grid.xml").write_text(GRID)
    return str(tmp / "lab.xml"), str(tmp / "grid.xml")


def _left(deadline: float) -> float:
    """The seconds left until ``deadline`` (monotonic), none once it has passed."""
    return max(deadline - time.monotonic(), 0.0)


def test_registration_is_accepted_or_refused_with_its_reason(net: Net) -> None:
    lab, grid = _maps(net.tmp)
    net.spawn("world", lab, "--grid", grid)
    bus = net.client()
    ok = register(bus, net.sim, RobotSpecMsg(name="a"))
    assert ok.ok
    assert (ok.robot_id, ok.spec.x_m, ok.spec.y_m) == (1, 2.0, 5.0)  # type: ignore[union-attr]
    dup = register(bus, net.sim, RobotSpecMsg(name="b", id=1))
    assert not dup.ok
    assert "id 1 is taken" in dup.reason
    bad = register(bus, net.sim, RobotSpecMsg(name="c", com=1.5))
    assert not bad.ok
    assert "com" in bad.reason
    on_wall = register(bus, net.sim, RobotSpecMsg(name="d", x_m=9.5, y_m=1.0))
    assert not on_wall.ok
    assert "wall" in on_wall.reason
    assert register(bus, net.sim, RobotSpecMsg(name="e")).ok
    assert register(bus, net.sim, RobotSpecMsg(name="f")).ok
    full = register(bus, net.sim, RobotSpecMsg(name="g"))
    assert not full.ok
    assert "grid is full" in full.reason


def _lockstep_run(
    net: Net, seed: int, *sensors_args: str
) -> tuple[list[tuple[int, tuple[float, ...]]], list[SensorReading]]:
    """A 3 s lock-step run of two wanderers: its states (tick, poses) and every reading."""
    lab, grid = _maps(net.tmp)
    bus = net.client()
    states = subscribe(bus, keys.state(net.sim))
    batches = subscribe(bus, keys.all_sensor_batches(net.sim))
    world = net.spawn(
        "world",
        lab,
        "--grid",
        grid,
        "--lockstep",
        "--expect",
        "2",
        "--duration",
        "3",
        "--seed",
        str(seed),
        name=f"world-{seed}",
    )
    net.spawn("collision", name=f"collision-{seed}")
    net.spawn("sensors", *sensors_args, name=f"sensors-{seed}")
    net.spawn("agent", "wanderer", "--count", "2", "--seed", str(seed), "--name", f"w{seed}", name=f"agent-{seed}")
    assert world.popen.wait(90) == 0, world.output()
    # the last states and readings may still be on their way when the world has exited: waited
    # for until a whole run's are here, then any more within 0.5 s
    deadline = time.monotonic() + 30
    out = []
    while (d := states.get(timeout_s=_left(deadline) if len(out) < RUN_TICKS else 0.5)) is not None:
        m = decode(d[1], WorldState)
        out.append((m.tick, tuple(m.x + m.y + m.heading)))
    readings = []
    while (d := batches.get(timeout_s=_left(deadline) if len(readings) < 2 * RUN_TICKS else 0.5)) is not None:
        # the wall clock of the tick's start differs from run to run, nothing else may
        readings += [msgspec.structs.replace(r, tick_wall_ns=0) for r in decode(d[1], SensorBatch).readings]
    return out, readings


def test_lockstep_runs_with_one_seed_give_identical_state_streams(tmp_path: Path) -> None:
    # the second run's sensors node does not compute ahead from the proposals: the readings,
    # and so everything else, must not change
    runs = []
    for i, args in enumerate(((), ("--no-ahead",))):
        n = Net(tmp_path / f"run{i}")
        n.tmp.mkdir()
        n.start_router()
        try:
            runs.append(_lockstep_run(n, 11, *args))
        finally:
            n.close()
    (states, readings), (states2, readings2) = runs
    assert [t for t, _ in states] == list(range(1, 31))  # 3 s of 100 ms ticks, none skipped
    assert states == states2
    assert len(readings) == 2 * 30
    assert readings == readings2
    moved = states[-1][1] != states[0][1]
    assert moved


def test_a_killed_agent_stops_its_chair(net: Net) -> None:
    lab, grid = _maps(net.tmp)
    bus, events, states = watch(net)
    net.spawn("world", lab, "--grid", grid)
    net.spawn("collision")
    net.spawn("sensors")
    agent = net.spawn("agent", "waypoint", "--waypoints", "8,5", "--id", "1", "--name", "driver")
    wait_msg(states, WorldState, lambda m: 1 in m.ids and m.speed[m.ids.index(1)] > 0.1)
    agent.kill(signal.SIGKILL)
    lost = wait_event(events, "agent-lost", timeout_s=10)  # the only agent: no earlier one
    assert lost.robot_id == 1
    stopped = wait_msg(states, WorldState, lambda m: m.tick > lost.tick and abs(m.speed[m.ids.index(1)]) < 1e-3)
    x = state_of(stopped, 1)[0]
    later = wait_msg(states, WorldState, lambda m: m.tick >= stopped.tick + 5)
    assert state_of(later, 1)[0] == pytest.approx(x, abs=1e-3)  # the motors wind down on their curve
    wait_event(events, "removed", timeout_s=15, pred=lambda e: e.robot_id == 1)


def test_silent_controller_trips_the_watchdog(net: Net) -> None:
    lab, grid = _maps(net.tmp)
    bus = net.client()
    events = subscribe(bus, keys.all_events(net.sim))
    states = subscribe(bus, keys.state(net.sim))  # every state: the chair moves for about a second only
    net.spawn("world", lab, "--grid", grid, "--action-timeout-ms", "1000")
    net.spawn("collision")
    # the one command (stale after 1 s, ten ticks) must not go stale while the world holds the chair
    # for want of verdicts: the collision process is there, and has given the new roster a verdict
    wait_alive(bus, keys.alive(net.sim, "collision", "collision"))
    rid = register(bus, net.sim, RobotSpecMsg(name="raw")).robot_id
    wait_msg(states, WorldState, lambda m: rid in m.ids and not m.held)
    bus.publish(keys.actions(net.sim, rid), encode(Actions(robot_id=rid, left=0.1, right=0.1)))
    wait_msg(states, WorldState, lambda m: rid in m.ids and m.speed[m.ids.index(rid)] > 0.05)
    ev = wait_event(events, "watchdog")
    assert ev.robot_id == rid
    wait_msg(states, WorldState, lambda m: m.tick > ev.tick and abs(m.speed[m.ids.index(rid)]) < 1e-3)


def test_without_collision_process_every_chair_is_held_until_it_returns(net: Net) -> None:
    lab, grid = _maps(net.tmp)
    bus, events, states = watch(net)
    net.spawn("world", lab, "--grid", grid)
    collision = net.spawn("collision")
    net.spawn("sensors")
    net.spawn("agent", "waypoint", "--waypoints", "18,5", "--id", "1", "--name", "driver")
    running = wait_msg(states, WorldState, lambda m: 1 in m.ids and m.speed[m.ids.index(1)] > 0.1 and not m.held)
    collision.kill(signal.SIGKILL)
    hold = wait_event(events, "holding", timeout_s=10, pred=lambda e: e.tick >= running.tick)
    held = wait_msg(states, WorldState, lambda m: m.held and m.tick > hold.tick)
    later = wait_msg(states, WorldState, lambda m: m.tick >= held.tick + 5)
    assert later.held
    assert state_of(later, 1)[:2] == state_of(held, 1)[:2]
    net.spawn("collision", name="collision-again")
    # a process started on a loaded machine: its first verdicts may still be late (a tick held)
    back = wait_event(events, "resumed", timeout_s=60, pred=lambda e: e.tick > hold.tick)
    moving = wait_msg(states, WorldState, lambda m: m.tick > back.tick + 3 and not m.held)
    assert state_of(moving, 1)[0] > state_of(held, 1)[0]


def test_real_time_with_a_collision_process_answering_never_holds_a_robot(net: Net) -> None:
    # issue #22 item 3: the world waits for the verdict as long as the period allows, so a
    # collision process that answers within the period holds nobody, from the robot's first
    # tick on (the collision process warms the new roster before its first proposal)
    lab, grid = _maps(net.tmp)
    bus = net.client()
    events = subscribe(bus, keys.all_events(net.sim))
    states = subscribe(bus, keys.state(net.sim))
    net.spawn("world", lab, "--grid", grid)
    net.spawn("collision")
    net.spawn("sensors")
    wait_alive(bus, keys.alive(net.sim, "collision", "collision"))
    wait_alive(bus, keys.alive(net.sim, "world", "world"))
    net.spawn("agent", "waypoint", "--waypoints", "18,5", "--id", "1", "--name", "driver")
    first = wait_msg(states, WorldState, lambda m: 1 in m.ids)
    seen = [first]
    while len(seen) < 30:
        seen.append(wait_msg(states, WorldState, lambda m: 1 in m.ids, timeout_s=10))
    held = [m.tick for m in seen if m.held]
    assert not held, f"robots held at ticks {held} with a collision process alive"
    assert state_of(seen[-1], 1)[0] > state_of(first, 1)[0]  # it drove meanwhile
    holds = [e.reason for e in (decode(d, Event) for _, d, _ in events.drain()) if e.kind == "holding"]
    assert not holds, holds


def test_demo_scenario_runs_meets_its_criteria_and_is_recorded(tmp_path: Path) -> None:
    # lock-step, so the verdict does not depend on how loaded the machine is
    argv = iwz_run_argv(
        MAPS / "scenarios" / "demo.toml", tmp_path, "demo", record=tmp_path / "demo.mcap", extra=("--lockstep",)
    )
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = p.communicate(timeout=110)
    except subprocess.TimeoutExpired:
        out, err = stop_run(p)
        pytest.fail(f"the demo still ran after 110 s, stopped:\n{out}{err}")
    r = subprocess.CompletedProcess(argv, p.returncode, out, err)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "PASS robot 1 within 0.5 m of (20, 6.1)" in r.stdout
    assert "PASS collisions 0" in r.stdout
    health = check(tmp_path / "demo.mcap")  # recorded by default, whole, nothing missing
    assert health.whole, health.reason
    assert health.counts_match


def test_a_batched_agent_host_reads_sensor_batches_and_answers_in_one_message(net: Net) -> None:
    lab, grid = _maps(net.tmp)
    bus = net.client()
    states = subscribe(bus, keys.state(net.sim))
    batches = subscribe(bus, keys.all_agent_actions(net.sim))
    per_robot_actions = subscribe(bus, keys.all_actions(net.sim))
    sensor_batches = subscribe(bus, keys.all_sensor_batches(net.sim))
    own = subscribe(bus, keys.sensors(net.sim, 2))
    events = subscribe(bus, keys.all_events(net.sim))
    world = net.spawn("world", lab, "--grid", grid, "--lockstep", "--expect", "2", "--duration", "3")
    net.spawn("collision")
    net.spawn("sensors")
    net.spawn("agent", "wanderer", "--count", "2", "--seed", "3", "--batch", "on", "--name", "herd")
    assert world.popen.wait(90) == 0, world.output()
    deadline = time.monotonic() + 30  # the last states may still be on their way when the world has exited
    ticks = []
    while (d := states.get(timeout_s=_left(deadline) if len(ticks) < RUN_TICKS else 0.5)) is not None:
        ticks.append(decode(d[1], WorldState))
    assert [m.tick for m in ticks] == list(range(1, 31))  # every tick answered, none waited out
    assert ticks[-1].x != ticks[0].x or ticks[-1].heading != ticks[0].heading
    got = wait_msg(batches, ActionBatch, lambda b: b.tick == 5)
    assert got.agent == "herd"
    assert sorted(a.robot_id for a in got.actions) == [1, 2]
    assert per_robot_actions.get(timeout_s=0.5) is None  # the batch replaced them
    # the shard's batch carries exactly what the robot's own key carries
    batch = wait_msg(sensor_batches, SensorBatch, lambda b: b.tick == 7)
    mine = wait_msg(own, SensorReading, lambda r: r.tick == 7)
    assert batch.shard == "1-1"
    assert [r for r in batch.readings if r.robot_id == 2] == [mine]
    while (d := events.get(timeout_s=0.2)) is not None:
        assert decode(d[1], Event).kind != "laggard"


def test_the_world_takes_a_batch_only_for_the_senders_own_robots(net: Net) -> None:
    lab, grid = _maps(net.tmp)
    bus, events, states = watch(net)
    net.spawn("world", lab, "--grid", grid)
    net.spawn("collision")
    mine = register(bus, net.sim, RobotSpecMsg(name="mine"), agent="tester").robot_id
    theirs = register(bus, net.sim, RobotSpecMsg(name="theirs"), agent="someone").robot_id

    def go(agent: str, on_key_of: str, rid: int) -> None:
        batch = ActionBatch(agent=agent, actions=[Actions(robot_id=rid, left=0.1, right=0.1)])
        bus.publish(keys.agent_actions(net.sim, on_key_of), encode(batch))

    go("tester", "tester", theirs)
    ev = wait_event(events, "bad-message", timeout_s=10)
    assert f"robot {theirs}, not its own" in ev.reason
    go("tester", "impostor", mine)
    ev = wait_event(events, "bad-message", timeout_s=10)
    assert "another agent's key" in ev.reason
    # sent again every half second, as an agent sends every tick: the world may still hold its
    # robots (no collision process heard yet) when one batch comes, and its watchdog zeroes it
    moving = None
    deadline = time.monotonic() + 20
    while moving is None and time.monotonic() < deadline:
        go("tester", "tester", mine)
        with contextlib.suppress(AssertionError):
            moving = wait_msg(states, WorldState, lambda m: mine in m.ids and m.speed[m.ids.index(mine)] > 0.05, 0.5)
    assert moving is not None, "the sender's own robot never moved"
    assert abs(moving.speed[moving.ids.index(theirs)]) < 1e-9  # the refused batches moved nothing


def test_the_sensors_node_catches_up_a_tick_of_backlog(net: Net) -> None:
    # the test plays the world: tick 1's state, then, while the sensors node waits for the world's
    # description (which the test holds back), ticks 2 and 3 back to back: a backlog of two,
    # as after a slow tick. Every tick's readings must come, none skipped.
    from iw_zenoh.core.lab import Grid, GridPosition, Lab
    from iw_zenoh.messages import Proposed, RegisterRequest, Verdict
    from iw_zenoh.sim.config import MS, WorldConfig
    from iw_zenoh.sim.world import WorldCore

    core = WorldCore(WorldConfig(sim=net.sim), Lab("t", 20.0, 10.0), Grid((GridPosition(2, 5, 0),)))
    assert core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)[0].ok
    states = []
    for n in (1, 2, 3):
        prop = next(m for _, m in core.begin_tick(n * 100 * MS) if isinstance(m, Proposed))
        verdict = Verdict(tick=prop.tick, revision=prop.revision, ids=prop.ids, collided=[False])
        states.append(next(m for _, m in core.finish_tick(verdict) if isinstance(m, WorldState)))
    bus = net.client()
    info_q = bus.serve(keys.info(net.sim))
    readings = subscribe(bus, keys.sensors(net.sim, 1))
    net.spawn("sensors")
    wait_alive(bus, keys.alive(net.sim, "sensors", "sensors-1-1"))
    bus.publish(keys.state(net.sim), encode(states[0]))
    deadline = time.monotonic() + 30
    asked = []
    while not (asked := info_q.poll()):  # the node is now waiting for the description
        assert time.monotonic() < deadline, "the sensors node never asked for world/info"
        time.sleep(0.005)  # polling the test's own queryable: there is no event to wait on
    for st in states[1:]:
        bus.publish(keys.state(net.sim), encode(st))
    asked[0].reply(encode(core.info()))
    got: set[int] = set()
    while got != {1, 2, 3} and time.monotonic() < deadline:
        for q in info_q.poll():
            q.reply(encode(core.info()))
        d = readings.get(timeout_s=0.05)
        if d is not None:
            got.add(decode(d[1], SensorReading).tick)
    assert got == {1, 2, 3}


_CRASH = """
import ctypes, sys
from iw_zenoh.process.runtime import start_role
sys.exit(start_role(["--sim", "crash", "--mode", "peer"], role="crash", description="d", run=lambda p: ctypes.string_at(0)))
"""


def test_a_role_that_crashes_in_native_code_leaves_its_threads_stacks_in_its_log() -> None:
    # the viewer died of SIGSEGV with an empty log, so nobody could tell where: now the log says
    p = subprocess.run([sys.executable, "-c", _CRASH], capture_output=True, text=True, timeout=60)
    assert p.returncode == -signal.SIGSEGV
    assert "Fatal Python error: Segmentation fault" in p.stderr
    assert "in start_role" in p.stderr
