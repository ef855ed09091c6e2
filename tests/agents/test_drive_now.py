"""A driver's input answered at once, between ticks (agents/manual.py ``drive_now``, the agent
host's ``DrivesNow``): the key's latency is the network's, not up to a tick's, and the answer keeps
every rule of the tick's own: the comfort ramp against whichever command the world applied, shared
control at a wall and a doorway, the dead-man; lock-step runs and replayed traces answer on ticks
only (tests/integration/test_driving.py replays the slalom trace to PASS through real processes)."""

from __future__ import annotations

import pytest
from iw_zenoh.agents.manual import ManualChair
from iw_zenoh.agents.mapping_chair import mapping_chair

from iw_zenoh import keys
from iw_zenoh.agent import AgentHost
from iw_zenoh.core.assist import ramp
from iw_zenoh.core.lab import Lab
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import Actions, DriveInput, DriveState, SensorReading, decode, encode
from iw_zenoh.sim.local import LocalWorld
from tests.agents.test_manual import DOOR, FRONT_M, WALL
from tests.support.builders import agent_host
from tests.support.fakes import FakeBus

S = 1_000_000_000


def _push(rid: int, seq: int, y: float = 1.0, level: int = 5, buttons: int = 1) -> DriveInput:
    return DriveInput(robot_id=rid, driver="p", seq=seq, y=y, buttons=buttons, level=level)


def _between(lab: Lab, start: tuple[float, float], assist: str, ticks: int) -> tuple[LocalWorld, bool]:
    """A push forward whose every input comes between two ticks and is answered at once: the
    world applies the answer again (the newest actions), not the tick's own."""
    w = LocalWorld(lab, seed=1)
    rid = w.add(mapping_chair("m", id=1, x_m=start[0], y_m=start[1], dir_deg=0.0))
    chair = ManualChair(w.spec(rid), assist=assist, clock=lambda: 0.0)
    chair.on_registered(rid, w.spec(rid))
    s, hit = w.step({}), False
    for k in range(ticks):
        chair.on_sensors(s.readings[rid], [])  # the tick's answer, made with the input before
        chair.on_drive(_push(rid, k, y=1.0 if k % 2 else 0.9, level=3))  # a new input: the stick moved
        again = chair.drive_now()
        assert again is not None
        s = w.step({rid: again})
        hit = hit or s.readings[rid].collision
    return w, hit


def test_safe_stops_a_push_into_a_wall_short_of_it_when_each_input_is_answered_between_ticks() -> None:
    w, hit = _between(WALL, (6.0 - 2.0 - FRONT_M, 3.0), "safe", 200)
    assert w.state is not None
    assert not hit
    assert 6.0 - (w.state.x[0] + FRONT_M) >= 0.05
    assert w.state.speed[0] == pytest.approx(0.0, abs=1e-3)


def test_assist_still_takes_a_push_at_a_doorways_edge_through_it_when_answered_between_ticks() -> None:
    w, hit = _between(DOOR, (3.0, 3.3), "assist", 150)
    assert w.state is not None
    assert not hit
    assert w.state.x[0] - 0.2 > 6.2


def _reading(tick: int, rid: int = 1) -> SensorReading:
    return SensorReading(
        tick=tick,
        sim_time_ns=tick * S // 20,
        robot_id=rid,
        proximity_ids=[],
        proximity_m=[],
        proximity_legacy=[],
        compass_deg=0.0,
        gps=(0, 0, 0),
    )


def test_every_command_is_within_a_ticks_comfort_ramp_of_each_one_sent_this_tick_and_the_tick_before() -> None:
    # the world applies whichever actions came last before its step: an answer sent again, or the
    # tick's own if the answer again came after the step; either way the chair's next command is
    # one tick's comfort acceleration (braking at twice it) from it
    chair = ManualChair(mapping_chair("m", id=1), clock=lambda: 0.0)
    lim = chair.lim
    sent: list[list[tuple[float, float]]] = []
    inputs = [(1.0, 1), (0.0, 0), (1.0, 1), (-1.0, 1), (1.0, 1), (0.3, 1), (0.0, 0)]
    for tick in range(1, 40):
        chair.on_sensors(_reading(tick), [])
        this = [chair.cmd]
        for k, (y, buttons) in enumerate(inputs[tick % 3 : tick % 3 + 1 + tick % 4]):
            chair.on_drive(_push(1, tick * 10 + k, y=y, buttons=buttons))
            if chair.drive_now() is not None:
                this.append(chair.cmd)
        sent.append(this)
    assert sum(len(s) > 1 for s in sent) > 20  # inputs were answered between ticks
    for n in range(1, len(sent)):
        for i, c in enumerate(sent[n]):
            for p in [*sent[n - 1], *sent[n][:i]]:
                assert ramp(p, c, 0.05, lim) == pytest.approx(c, abs=1e-9), (n, p, c)


def test_an_input_that_changes_nothing_a_stale_driver_and_a_replayed_trace_are_not_answered_again() -> None:
    now = [0.0]
    chair = ManualChair(mapping_chair("m", id=1), clock=lambda: now[0])
    assert chair.drive_now() is None  # no tick yet
    chair.on_drive(_push(1, 1))
    chair.on_sensors(_reading(1), [])
    chair.on_drive(_push(1, 2))  # the same stick
    assert chair.drive_now() is None
    now[0] = 1.0  # the dead-man tripped: the next tick stops the chair, not an answer between
    assert chair.drive_now() is None
    traced = ManualChair(mapping_chair("m", id=1), trace=[_push(1, 1)], clock=lambda: now[0])
    traced.on_sensors(_reading(1), [])
    traced.on_drive(_push(1, 2, y=-1.0))
    assert traced.drive_now() is None


def _driven() -> tuple[FakeBus, AgentHost]:
    host, bus = agent_host(ManualChair(RobotSpec("m")), world_tick=50)
    host.readings.put((keys.sensors("t", 1), encode(_reading(51)), 0))
    assert host.step(timeout_s=0)
    return bus, host


def _actions(bus: FakeBus) -> list[Actions]:
    return [decode(d, Actions) for k, d in bus.published if k == keys.actions("t", 1)]


def test_the_host_sends_a_drivers_input_at_once_as_the_ticks_actions_and_drive_state() -> None:
    bus, host = _driven()
    [stood] = _actions(bus)
    assert (stood.tick, stood.left, stood.right) == (51, 0.0, 0.0)
    host.drives.put((keys.drive("t", 1), encode(_push(1, 7, level=1)), 0))
    host.step(timeout_s=0)
    _, moved = _actions(bus)
    assert moved.tick == 51  # the same tick, answered again: no new reading came
    assert moved.left > 0
    assert moved.right > 0
    states = [decode(d, DriveState) for k, d in bus.published if k == keys.driving("t", 1)]
    assert states[-1].seq == 7
    assert states[-1].v_mps > 0


def test_in_lock_step_the_host_answers_a_drivers_input_at_the_next_tick_only() -> None:
    bus, host = _driven()
    host.lockstep = True
    host.drives.put((keys.drive("t", 1), encode(_push(1, 7)), 0))
    host.step(timeout_s=0)
    assert len(_actions(bus)) == 1
    host.readings.put((keys.sensors("t", 1), encode(_reading(52)), 0))
    assert host.step(timeout_s=0)
    assert _actions(bus)[-1].tick == 52
    assert _actions(bus)[-1].left > 0
