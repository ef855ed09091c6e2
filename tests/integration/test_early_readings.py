"""Readings published as soon as the collision verdict confirms the proposal, before the world's
state: a real sensors process on a real router, the world played by the test (so which message
comes when is the test's to say, not a race), then a whole lock-step run with a chair driven into
a wall."""

from __future__ import annotations

import math
import time
from pathlib import Path

import msgspec
import pytest

from iw_zenoh import keys
from iw_zenoh.bus import Inbox
from iw_zenoh.convert import lab_from_msg, spec_from_msg
from iw_zenoh.core.lab import Grid, GridPosition, Lab, Scene
from iw_zenoh.messages import (
    Actions,
    Proposed,
    RadioBatch,
    RegisterRequest,
    RobotSpecMsg,
    Say,
    SensorReading,
    Verdict,
    WorldInfo,
    WorldState,
    decode,
    encode,
)
from iw_zenoh.sim.config import MS, WorldConfig
from iw_zenoh.sim.sensors import SensorsNode
from iw_zenoh.sim.view import WorldView
from iw_zenoh.sim.world import WorldCore
from tests.integration.harness import MAPS, Net, subscribe, wait_alive, wait_event, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(120)]


def _view(info: WorldInfo) -> WorldView:
    """The world as a sensors node sees it from its description."""
    lab = lab_from_msg(info.lab)
    return WorldView(info, Scene(lab), {s.id: spec_from_msg(s) for s in info.robots})


class _PlayedWorld:
    """The world's logic in the test, its proposals, verdicts and states published by hand."""

    def __init__(self, net: Net) -> None:
        self.net = net
        self.core = WorldCore(WorldConfig(sim=net.sim), Lab("t", 20.0, 10.0), Grid((GridPosition(2, 5, 0),)))
        assert self.core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)[0].ok
        self.core.collision_alive.add("c")
        self.bus = net.client()
        self.info_q = self.bus.serve(keys.info(net.sim))
        self.readings = subscribe(self.bus, keys.sensors(net.sim, 1))
        self.got: list[SensorReading] = []
        self.states: list[WorldState] = []

    def propose(self, n: int) -> Proposed:
        self.core.on_actions(Actions(tick=n - 1, robot_id=1, left=0.15, right=0.1), n * 100 * MS)
        prop = next(m for _, m in self.core.begin_tick(n * 100 * MS, n) if isinstance(m, Proposed))
        self.bus.publish(keys.proposed(self.net.sim), encode(prop))
        return prop

    def verdict(self, prop: Proposed, collided: bool) -> Verdict:
        v = Verdict(tick=prop.tick, revision=prop.revision, ids=prop.ids, collided=[collided])
        self.bus.publish(keys.verdict(self.net.sim), encode(v))
        return v

    def commit(self, v: Verdict | None) -> WorldState:
        st = next(m for _, m in self.core.finish_tick(v) if isinstance(m, WorldState))
        self.bus.publish(keys.state(self.net.sim), encode(st))
        self.states.append(st)
        return st

    def reading(self, tick: int, timeout_s: float = 30.0) -> SensorReading:
        """The next reading of ``tick`` (answering the node's questions for the world's info)."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for q in self.info_q.poll():
                q.reply(encode(self.core.info()))
            d = self.readings.get(timeout_s=0.05)
            if d is not None:
                r = decode(d[1], SensorReading)
                self.got.append(r)
                if r.tick == tick:
                    return r
        raise AssertionError(f"no reading of tick {tick} within {timeout_s} s; got ticks {[r.tick for r in self.got]}")


def test_readings_go_out_when_the_verdict_confirms_and_a_held_tick_is_corrected(net: Net) -> None:
    w = _PlayedWorld(net)
    net.spawn("sensors")
    wait_alive(w.bus, keys.alive(net.sim, "sensors", "sensors-1-1"))
    w.bus.publish(keys.info(net.sim), encode(w.core.info()))
    w.commit(w.verdict(w.propose(1), collided=False))  # the node's first state: none before it to compute from
    w.reading(1)
    for n in (2, 3):  # confirmed: the readings come though the world has not committed the tick
        prop = w.propose(n)
        w.verdict(prop, collided=False)
        w.reading(n)
        w.commit(Verdict(tick=prop.tick, revision=prop.revision, ids=prop.ids, collided=[False]))
    # confirmed, but the world held the tick (the verdict came after its deadline): the early
    # readings are corrected, from the state
    w.verdict(w.propose(4), collided=False)
    early = w.reading(4)
    held = w.commit(None)
    assert held.held
    fixed = w.reading(4)
    assert fixed != early
    assert fixed.gps[:2] != early.gps[:2]
    # and the tick after reads on from the held state, early again
    prop = w.propose(5)
    w.verdict(prop, collided=False)
    w.reading(5)
    w.commit(Verdict(tick=prop.tick, revision=prop.revision, ids=prop.ids, collided=[False]))
    # a verdict that flags the robot: its readings wait for the state, and say it collided
    w.commit(w.verdict(w.propose(6), collided=True))
    assert w.reading(6).collision
    assert [r.tick for r in w.got] == [1, 2, 3, 4, 4, 5, 6]  # one reading a tick, the correction the only second
    # the newest reading of every tick is the one a node computing from each committed state gives
    reference = SensorsNode(net.sim, w.core.cfg.seed)
    view = _view(w.core.info())
    want = [reference.on_state(st, view)[0][1] for st in w.states]
    assert [r for i, r in enumerate(w.got) if i + 1 == len(w.got) or w.got[i + 1].tick != r.tick] == want


def test_no_early_waits_for_the_state(net: Net) -> None:
    w = _PlayedWorld(net)
    net.spawn("sensors", "--no-early")
    wait_alive(w.bus, keys.alive(net.sim, "sensors", "sensors-1-1"))
    w.commit(w.verdict(w.propose(1), collided=False))
    w.reading(1)
    prop = w.propose(2)
    w.verdict(prop, collided=False)
    with pytest.raises(AssertionError, match="no reading of tick 2"):
        w.reading(2, timeout_s=2.0)  # nothing comes before the state ...
    w.commit(Verdict(tick=prop.tick, revision=prop.revision, ids=prop.ids, collided=[False]))
    w.reading(2)  # ... and it comes with it


def test_the_radio_delivers_a_confirmed_tick_before_its_state_and_again_if_it_was_held(net: Net) -> None:
    w = _PlayedWorld(net)
    radio = subscribe(w.bus, keys.radio(net.sim))
    net.spawn("radio")
    wait_alive(w.bus, keys.alive(net.sim, "radio", "radio"))
    w.commit(w.verdict(w.propose(1), collided=False))  # its first state: a tick to follow on from
    assert wait_msg(radio, RadioBatch, lambda b: b.tick == 1).hear == []
    w.bus.publish(keys.say(net.sim, 1), encode(Say(robot_id=1, text="hi")))
    prop = w.propose(2)
    w.verdict(prop, collided=False)
    got = wait_msg(radio, RadioBatch)  # before the world committed tick 2
    assert (got.tick, [[m.text for m in h.messages] for h in got.hear]) == (2, [["hi"]])
    w.commit(Verdict(tick=prop.tick, revision=prop.revision, ids=prop.ids, collided=[False]))
    w.bus.publish(keys.say(net.sim, 1), encode(Say(robot_id=1, text="again")))
    w.verdict(w.propose(3), collided=False)
    assert wait_msg(radio, RadioBatch).tick == 3
    w.commit(None)  # held after all: delivered again where the robot is
    again = wait_msg(radio, RadioBatch)
    assert (again.tick, [[m.text for m in h.messages] for h in again.hear]) == (3, [["again"]])


AGENT = '''
from iw_zenoh.agent import Command
from iw_zenoh.core.spec import RobotSpec, SensorNoise


class Straight:
    """Drives straight at a fixed power from where it is placed (exact sensors)."""

    def __init__(self, name, x, y, power):
        self.name, self.x, self.y, self.power = name, x, y, power

    def spec(self):
        return RobotSpec(self.name, width_m=1.04, height_m=0.66, x_m=self.x, y_m=self.y, dir_deg=0.0,
                         noise=SensorNoise.off())

    def on_sensors(self, reading, heard):
        return Command(self.power, self.power)


def make(args):
    # one into the wall ahead of it, one across the open lab
    return [Straight("pusher", 7.5, 1.5, 0.15), Straight("free", 2.0, 7.0, 0.05)]
'''

LAB = """<Lab Name="test" Width="20" Height="10">
  <Wall Height="2"><Corner X="9" Y="0"/><Corner X="10" Y="0"/><Corner X="10" Y="3"/><Corner X="9" Y="3"/></Wall>
</Lab>"""


def test_a_lockstep_run_into_a_wall_reads_every_committed_pose(tmp_path: Path, net: Net) -> None:
    (tmp_path / "straight.py").write_text(AGENT)
    (tmp_path / "lab.xml").write_text(LAB)
    bus = net.client()
    states = subscribe(bus, keys.state(net.sim))
    readings = subscribe(bus, keys.all_sensors(net.sim))
    both = Inbox()  # states and readings in the order they arrived
    bus.subscribe(keys.state(net.sim), both)
    bus.subscribe(keys.all_sensors(net.sim), both)
    world = net.spawn("world", str(tmp_path / "lab.xml"), "--lockstep", "--expect", "2", "--duration", "3")
    net.spawn("collision")
    net.spawn("sensors")
    net.spawn("agent", str(tmp_path / "straight.py"), "--name", "straight")
    assert world.popen.wait(90) == 0, world.output()
    committed: dict[int, WorldState] = {}
    while (d := states.get(timeout_s=0.5)) is not None:
        m = decode(d[1], WorldState)
        committed[m.tick] = m
    last: dict[tuple[int, int], SensorReading] = {}  # the newest reading of each robot and tick
    while (d := readings.get(timeout_s=0.5)) is not None:
        r = decode(d[1], SensorReading)
        last[(r.tick, r.robot_id)] = r
    assert sorted(committed) == list(range(1, 31))
    assert any(any(s.collided) for s in committed.values())  # the pusher hit the wall
    assert any(not any(s.collided) and s.x != committed[1].x for s in committed.values())  # ticks confirmed too
    # readings of a tick the verdict confirmed came before the world's state of it (the world
    # commits as the sensors publish, so not every tick: never, were they waiting for the state)
    first: dict[int, str] = {}
    while (d := both.get(timeout_s=0.5)) is not None:
        tick = decode(d[1], WorldState if d[0] == keys.state(net.sim) else SensorReading).tick
        first.setdefault(tick, d[0])
    confirmed = [t for t, s in committed.items() if not any(s.collided)]
    assert any(first[t] != keys.state(net.sim) for t in confirmed)
    for tick, st in committed.items():
        for i, rid in enumerate(st.ids):
            r = last[(tick, rid)]
            x, y, heading = r.gps
            assert (x, y) == pytest.approx((st.x[i], st.y[i]), abs=1e-9), f"tick {tick} robot {rid}"
            assert abs(math.remainder(heading - math.degrees(st.heading[i]), 360.0)) < 1e-6, f"tick {tick} robot {rid}"
            assert r.collision == st.collided[i], f"tick {tick} robot {rid}"


def _convoy_run(net: Net, *early: str) -> tuple[list[bytes], list[bytes]]:
    """A 3 s lock-step convoy (a leader and a follower that hears it over the radio): every state
    and every radio batch, as published (with each tick's wall clock zeroed)."""
    bus = net.client()
    states = subscribe(bus, keys.state(net.sim))
    radio = subscribe(bus, keys.radio(net.sim))
    events = subscribe(bus, keys.all_events(net.sim))
    world = net.spawn(
        "world", str(MAPS / "hospital.xml"), "--grid", str(MAPS / "hospital-grid.xml"), "--lockstep",
        "--expect", "2", "--duration", "3", "--seed", "4",
    )  # fmt: skip
    net.spawn("collision")
    net.spawn("sensors", *early)
    net.spawn("radio", *early)
    leader = ("--role", "leader", "--id", "2", "--waypoints", "34,9.5")
    net.spawn("agent", "convoy", *leader, "--name", "leader", name="leader")
    # the leader registers first in both runs: the roster's order (and so the arrays') is the same
    wait_event(events, "registered", timeout_s=60, pred=lambda e: e.robot_id == 2)
    net.spawn("agent", "convoy", "--role", "follower", "--id", "1", "--follow", "2", "--name", "f", name="follower")
    assert world.popen.wait(90) == 0, world.output()
    out: tuple[list[bytes], list[bytes]] = ([], [])
    while (d := states.get(timeout_s=0.5)) is not None:
        out[0].append(encode(msgspec.structs.replace(decode(d[1], WorldState), tick_wall_ns=0)))
    while (d := radio.get(timeout_s=0.5)) is not None:
        out[1].append(d[1])
    return out


def test_lockstep_with_a_radio_is_the_same_run_early_or_not(tmp_path: Path) -> None:
    runs = []
    for i, early in enumerate(((), ("--no-early",))):
        n = Net(tmp_path / f"run{i}")
        n.tmp.mkdir()
        n.start_router()
        try:
            runs.append(_convoy_run(n, *early))
        finally:
            n.close()
    (states, heard), (states2, heard2) = runs
    assert len(states) == 30
    assert states == states2
    assert any(b"P 2 " in h for h in heard)  # the leader said where it is, and the follower heard it
    assert heard == heard2
