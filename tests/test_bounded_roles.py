"""Every role's memory is bounded by what it holds, not by how long it runs (issue #23), continued:
inboxes nobody drains, the launcher's tally, the bridge's referee and registrar, the agent host,
the Foxglove scene and live channels, the router's refusal log, the world's obstacles and views
(thousands of entries come and go; each test fails if its table keeps them)."""

from __future__ import annotations

import logging
import threading

import pytest
from iw_zenoh.bridges.ciberrato.referee import Referee
from iw_zenoh.bridges.ciberrato.registrar import Registrar
from iw_zenoh.bridges.ciberrato.registration import parse_registration
from iw_zenoh.bridges.ciberrato.scoring import Mode

from iw_zenoh import keys
from iw_zenoh.agent import BATCHES_KEPT, HEARD_KEPT, AgentHost
from iw_zenoh.agent.hosting import KEYS_KEPT, Command, Outbox
from iw_zenoh.bus import INBOX_KEPT, NEWEST_KEPT, Inbox
from iw_zenoh.convert import spec_from_msg
from iw_zenoh.core.lab import Grid, GridPosition, Lab, Scene
from iw_zenoh.core.params import SimParameters
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.launch.tally import Tally
from iw_zenoh.messages import (
    Actions,
    Event,
    EventKind,
    Heard,
    IrSensorMsg,
    LabMsg,
    Obstacle,
    RegisterReply,
    RegisterRequest,
    RobotSpecMsg,
    SensorReading,
    WorldInfo,
    encode,
)
from iw_zenoh.nodes import foxglove_live
from iw_zenoh.process.runtime import NodeIO
from iw_zenoh.record.foxglove import SceneBuilder
from iw_zenoh.scenario.tables import Criteria, Reach
from iw_zenoh.secure.denials import KEPT, REPEAT_NS, DenialLog
from iw_zenoh.sim.config import WorldConfig
from iw_zenoh.sim.obstacles import MAX_OBSTACLES, Obstacles
from iw_zenoh.sim.view import ROSTERS_KEPT, WorldView
from iw_zenoh.sim.world import WorldCore
from iw_zenoh.viewer.sources import LIVE_KEPT, LiveSource
from tests.support.builders import world_state
from tests.support.fakes import FakeBus

COMERS = 5000  # robots, sessions or keys that come and go in a long run


# --- inboxes ----------------------------------------------------------------------------------


def test_an_inbox_nobody_drains_keeps_its_bound_and_counts_and_logs_what_it_lost(
    caplog: pytest.LogCaptureFixture,
) -> None:
    box = Inbox(maxlen=100)
    for n in range(COMERS):
        box.put((f"k{n}", b"", n))
    assert len(box) == 100
    with caplog.at_level(logging.WARNING, logger="iw_zenoh.bus"):
        got = box.drain()
        box.put(("again", b"", 0))
        assert box.get(0) is not None
    assert [d[2] for d in got] == list(range(COMERS - 100, COMERS))  # the newest, in order
    assert box.lost == COMERS - 100
    [line] = [r.getMessage() for r in caplog.records]  # once: nothing more was lost since
    assert f"{COMERS - 100} deliveries lost" in line


def test_an_inbox_is_bounded_unless_told_otherwise() -> None:
    box = Inbox()
    for n in range(INBOX_KEPT + 10):
        box.put(("k", b"", n))
    assert len(box) == INBOX_KEPT


def test_a_nodes_inbox_keeps_the_newest_few_of_a_key_whose_messages_supersede_each_other(
    caplog: pytest.LogCaptureFixture,
) -> None:
    io = NodeIO(FakeBus(), "t", "sensors", "s")
    states, actions = io.inbox(keys.state("t")), io.inbox(keys.all_actions("t"))
    for n in range(1000):
        states.put((keys.state("t"), b"", n))
        actions.put((keys.actions("t", n), b"", n))
    assert (len(states), len(actions)) == (NEWEST_KEPT, 1000)  # every action counts
    with caplog.at_level(logging.WARNING, logger="iw_zenoh.bus"):
        assert states.drain()[-1][2] == 999
    assert states.lost == 1000 - NEWEST_KEPT
    assert caplog.records == []  # losing superseded states is expected: no warning


def test_a_live_viewer_page_source_keeps_the_newest_deliveries() -> None:
    src = LiveSource(FakeBus(), "t", threading.Event())
    for n in range(COMERS):
        src.inbox.put((keys.state("t"), b"", n))
    assert len(src.inbox) == LIVE_KEPT
    assert src.inbox.drain()[0][2] == COMERS - LIVE_KEPT


# --- the launcher's tally ---------------------------------------------------------------------


def test_the_tally_forgets_robots_that_left_but_not_one_the_criteria_judge() -> None:
    t = Tally()
    crit = Criteria(reach=(Reach(robot=2, x_m=1.0, y_m=1.0, within_m=0.5),))
    t.on_state(world_state(1, [1, 2], collided=True), crit.reach)  # robot 2 reaches its goal ...
    for tick in range(2, COMERS):  # ... and leaves; others come and go
        t.on_state(world_state(tick, [1, tick + 10], x=3.0, collided=True), crit.reach)
        assert len(t.positions) <= 3
    assert sorted(t.positions) == [1, 2, COMERS + 9]
    assert t.reached == {2: 0.1}
    ok, lines = t.verdict(crit)
    assert ok
    assert lines == ["PASS robot 2 within 0.5 m of (1, 1) at t=0.1 s"]


def test_a_robot_named_by_the_criteria_that_left_is_judged_where_it_was_last_seen() -> None:
    t = Tally()
    crit = Criteria(reach=(Reach(robot=2, x_m=9.0, y_m=1.0, within_m=0.5),))
    t.on_state(world_state(1, [1, 2], x=4.0, collided=True), crit.reach)
    for tick in range(2, 100):
        t.on_state(world_state(tick, [1], x=5.0, collided=True), crit.reach)
    ok, lines = t.verdict(crit)
    assert not ok
    assert lines == ["FAIL robot 2 within 0.5 m of (9, 1): last at (4.00, 1.00)"]


# --- the legacy bridge ------------------------------------------------------------------------


def test_the_referee_forgets_the_collision_counts_of_native_robots_that_left() -> None:
    referee = Referee(SimParameters(), Mode.COMPETITIVE, lambda: None)
    for n in range(COMERS):
        ids = [1, n + 2]  # robot 1 stays, colliding all along; another comes, collides and goes
        referee.robot_states(world_state(n, ids, collided=True), {}, None, running=True)
        assert len(referee._hit) == len(referee._collisions) == 2
    assert sorted(referee._collisions) == [1, COMERS + 1]
    assert referee._collisions[1] == 1  # one collision all along: still counted once


def test_the_registrar_forgets_beacon_carriers_let_go() -> None:
    bus = FakeBus()
    bus.answer = lambda key, payload: None  # in flight: the world's answers do not matter here
    reg = Registrar(bus, "s", "ciberrato", SimParameters())
    beacon = RobotSpec("b", beacon_height_m=0.5)
    for n in range(1, COMERS):
        reg.accepted(n, beacon)  # a RobotBeacon served, then let go before the next one comes
        reg.admit(parse_registration(b'<Robot Name="r"/>'), ("127.0.0.1", 40_000 + n), None, (n,), 0.0)
        assert reg.carriers == {n}


# --- the agent host ---------------------------------------------------------------------------


class _Forward:
    def spec(self) -> RobotSpec:
        return RobotSpec("fwd")

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        return Command(0.1, 0.1)


class _Sub:
    def __init__(self, key: str, undeclared: list[str]) -> None:
        self.key, self._undeclared = key, undeclared

    def undeclare(self) -> None:
        self._undeclared.append(self.key)


class _SubscribingBus(FakeBus):
    """Hands out subscriptions that say when they are undeclared."""

    def __init__(self) -> None:
        super().__init__()
        self.subscribed: list[str] = []
        self.undeclared: list[str] = []

    def subscribe(self, key_expr: str, inbox: Inbox, *, ordered: bool = False) -> _Sub:  # type: ignore[override]
        self.subscribed.append(key_expr)
        return _Sub(key_expr, self.undeclared)


def _host(bus: _SubscribingBus) -> AgentHost:
    lab = LabMsg(name="l", width=5, height=5)
    bus.info = [encode(WorldInfo(tick=1, revision=1, lab=lab, period_ns=1))]
    return AgentHost(bus, "t", "host")


def _reply(rid: int) -> RegisterReply:
    return RegisterReply(tick=1, ok=True, robot_id=rid, spec=RobotSpecMsg(name="fwd", id=rid, x_m=1.0, y_m=1.0))


@pytest.mark.slow  # 5,000 registrations through an agent host (past the 4,096 keys kept): about 6 s of CPU
def test_the_agent_host_stops_listening_for_robots_the_world_removed() -> None:
    bus = _SubscribingBus()
    host = _host(bus)
    for rid in range(1, COMERS):
        bus.answer = lambda key, payload, rid=rid: [encode(_reply(rid))]  # type: ignore[misc]
        assert host.add(_Forward(), timeout_s=1.0) == rid
        removed = Event(kind=EventKind.REMOVED, robot_id=rid, reason="removed by control")
        host.removed.put((keys.event("t", EventKind.REMOVED), encode(removed), 0))
        host.step(timeout_s=0)
        assert len(host._subscribed) == len(host.hosted) == 0
    every = keys.all_sensors("t")  # heard while a robot's id is the world's to choose (asked 0)
    sensors = [k for k in bus.subscribed if k.endswith("/sensors") and k != every]
    assert len(sensors) == COMERS - 1
    assert bus.subscribed.count(every) == COMERS - 1
    assert host._robot_of_key == {}  # nor is any robot's sensors key kept
    assert sorted(bus.undeclared) == sorted([*sensors, *[every] * (COMERS - 1)])  # each given up, once


def test_the_agent_host_keeps_a_bounded_count_of_ticks_it_cannot_answer_yet() -> None:
    bus = _SubscribingBus()
    host = _host(bus)
    for rid in (1, 2):
        bus.answer = lambda key, payload, rid=rid: [encode(_reply(rid))]  # type: ignore[misc]
        host.add(_Forward(), timeout_s=1.0)
    host.lockstep = True  # waits for both robots' readings of a tick; robot 2's never come
    for tick in range(2, 2 + COMERS):
        host.readings.put((keys.sensors("t", 1), encode(_reading(tick)), 0))
        assert not host.step(timeout_s=0)
        assert len(host._fresh) <= HEARD_KEPT
    assert max(host._fresh) == COMERS + 1  # the newest kept
    host.readings.put((keys.sensors("t", 2), encode(_reading(COMERS + 1, rid=2)), 0))
    assert host.step(timeout_s=0)  # answered once the last robot's reading comes


def test_a_batched_agent_host_that_fell_behind_keeps_the_newest_sensor_batches() -> None:
    host = AgentHost(FakeBus(), "t", "host", batched=True)
    assert host.batches is not None
    for n in range(COMERS):
        host.batches.put((keys.sensor_batch("t", (1, 1)), b"", n))
    assert len(host.batches) == BATCHES_KEPT
    assert host.batches.drain()[-1][2] == COMERS - 1


def test_an_outbox_keeps_a_bounded_count_of_robots_actions_keys_and_each_goes_on_its_own() -> None:
    bus = FakeBus()
    out = Outbox(bus, "t", "host", batched=False)
    for rid in range(1, COMERS):
        out.command(rid, Command(0.1, 0.1), tick=rid, sim_time_ns=0)
        out.command(rid, Command(0.1, 0.1), tick=rid + 1, sim_time_ns=0)  # its key kept, not built again
        assert len(out._keys) <= KEYS_KEPT
    assert [k for k, _ in bus.published] == [keys.actions("t", rid) for rid in range(1, COMERS) for _ in (0, 1)]


def _reading(tick: int, rid: int = 1) -> SensorReading:
    return SensorReading(
        tick=tick, robot_id=rid, proximity_ids=[], proximity_m=[], proximity_legacy=[], compass_deg=0.0, gps=(0, 0, 0)
    )


# --- Foxglove, the router's log, the world's obstacles and views -------------------------------


def test_the_foxglove_scene_forgets_the_poses_of_robots_that_left() -> None:
    scene = SceneBuilder()
    robots = [RobotSpecMsg(name=f"r{i}", id=i, x_m=1.0, y_m=1.0) for i in range(1, COMERS + 2)]
    scene.on_info(WorldInfo(revision=1, lab=LabMsg(name="l", width=9, height=9), period_ns=1, robots=robots))
    for tick in range(1, COMERS):
        scene.on_state(world_state(tick, [1, tick + 1], collided=True))
        assert len(scene.pose) <= 2
    assert sorted(scene.pose) == [1, COMERS]


def test_the_routers_refusal_log_forgets_sessions_and_keys_of_long_ago() -> None:
    log = DenialLog()
    head = b"TRACE rx-0 ThreadId(08) zenoh::net::routing::interceptor::access_control: "
    for n in range(3 * KEPT):
        zid = f"{n:032x}"
        line = f"{zid} on CertCommonName(a{n}) is unauthorized to Put (ingress) on iw/s/robot/{n}/actions"
        denial = log.feed(head + line.encode(), n * REPEAT_NS // 1000)  # a thousand sessions a second
        assert denial is not None
        assert denial.identity == f"a{n}"
        assert len(log._names) <= KEPT
        assert len(log._last) <= KEPT + 1000  # those of the last second, and at most a second's more


def test_obstacles_beyond_the_limit_are_refused_with_it_and_those_removed_make_room() -> None:
    obs = Obstacles(Lab("l", 100.0, 100.0, ()))
    for n in range(COMERS):  # obstacles come and go
        assert obs.apply("add_obstacle", Obstacle(name=f"o{n}", x0=1, y0=1, x1=2, y1=2)) == ""
        assert obs.apply("remove_obstacle", Obstacle(name=f"o{n}", x0=0, y0=0, x1=0, y1=0)) == ""
    for n in range(MAX_OBSTACLES):
        assert obs.apply("add_obstacle", Obstacle(name=f"o{n}", x0=1, y0=1, x1=2, y1=2)) == ""
    why = obs.apply("add_obstacle", Obstacle(name="one-more", x0=1, y0=1, x1=2, y1=2))
    assert why == f"obstacle 'one-more': the world holds {MAX_OBSTACLES} obstacles already, the most it takes"
    assert obs.apply("move_obstacle", Obstacle(name="o0", x0=3, y0=3, x1=4, y1=4)) == ""  # moving one is no more


def test_a_view_keeps_the_bodies_of_a_few_rosters() -> None:
    robots = [RobotSpecMsg(name=f"r{i}", id=i, x_m=1.0, y_m=1.0) for i in range(1, 50)]
    info = WorldInfo(revision=1, lab=LabMsg(name="l", width=9, height=9), period_ns=1, robots=robots)
    view = WorldView(info, Scene(Lab("l", 9.0, 9.0, ())), {r.id: spec_from_msg(r) for r in robots})
    for n in range(COMERS):
        ids = [1 + (n + k) % 49 for k in range(3)]
        assert view.bodies_for(ids) is view.bodies_for(ids)  # built once while in use
        assert len(view._bodies) <= ROSTERS_KEPT


def test_foxglove_live_closes_the_channels_of_keys_gone_quiet_and_keeps_those_in_use(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(foxglove_live, "CHANNELS_KEPT", 32)
    live = foxglove_live.start_foxglove_live(NodeIO(FakeBus(), "t", "view", "v"), port=0)  # a real server
    try:
        data = encode(Actions(robot_id=1))
        live._publish((keys.actions("t", 1), data, 0))
        first = live._channels.get(keys.actions("t", 1)).channel
        for n in range(2, 2000):
            live._publish((keys.actions("t", 1), data, 0))  # in use all along
            live._publish((keys.actions("t", n), data, 0))  # a robot that acts once and leaves
            assert len(live._channels) <= 3 * 32
        assert live._channels.get(keys.actions("t", 1)).channel is first  # never closed while in use
    finally:
        live.close()


# --- hostile registrations ----------------------------------------------------------------------


def test_the_world_refuses_a_registration_too_big_for_every_tick_with_the_limit() -> None:
    core = WorldCore(WorldConfig(sim="t"), Lab("t", 20.0, 10.0, ()), Grid((GridPosition(2, 5, 0),)))
    sonars = [IrSensorMsg(id=i) for i in range(100_000)]
    reply, out = core.register(RegisterRequest(spec=RobotSpecMsg(name="a", ir_sensors=sonars), agent="x"), 0)
    assert not reply.ok
    assert reply.reason == "field ir_sensors: at most 64 per robot, got 100000 (every tick computes each one)"
    assert len(core.registry.entries) == 0
    reply, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="b", width_m=1e6), agent="x"), 0)
    assert (reply.ok, reply.reason) == (False, "field width_m: must be at most 10 m, got 1000000.0")


def test_a_legacy_registration_too_big_is_refused_with_the_limit() -> None:
    reg = Registrar(FakeBus(), "s", "ciberrato", SimParameters())
    adm = reg.admit(parse_registration(b'<Robot Name="x" Width="20" Height="20"/>'), ("127.0.0.1", 4000), None, (), 0.0)
    assert adm.answer
    assert "must be at most 10 m, got 20.0" in adm.refused
