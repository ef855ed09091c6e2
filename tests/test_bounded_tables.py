"""Every role's memory is bounded by what it holds, not by how long it runs (issue #23): tables
keyed by robot, request or key stay bounded while thousands of entries come and go (pure unit
tests on the tables' owners, no processes)."""

from __future__ import annotations

import pytest
from iw_zenoh.bridges.ciberrato import clients
from iw_zenoh.bridges.ciberrato.transport import Viewer

from iw_zenoh.bus.publishers import Publishers
from iw_zenoh.convert import spec_from_msg
from iw_zenoh.core.lab import Grid, GridPosition, Lab, Scene
from iw_zenoh.messages import (
    CollisionData,
    Event,
    EventKind,
    LabMsg,
    RegisteredData,
    RegisterRequest,
    RobotSpecMsg,
    SensorReading,
    WorldInfo,
    make_event,
)
from iw_zenoh.sim.config import WorldConfig
from iw_zenoh.sim.sensors import SensorsNode
from iw_zenoh.sim.view import WorldView
from iw_zenoh.sim.world import ANSWERS_KEPT, WorldCore
from iw_zenoh.viewer.feed import Feed
from tests.support.builders import world_state
from tests.support.fakes import FakeTransport

COMERS = 5000  # robots, requests or keys that come and go in a long run


@pytest.mark.slow  # 9,000 registrations in process (past the 4,096 answers kept): about 7 s of CPU
def test_registration_answers_kept_for_retries_are_bounded_and_a_retry_still_gets_its_answer() -> None:
    core = WorldCore(WorldConfig(sim="t"), Lab("t", 20.0, 10.0, ()), Grid((GridPosition(2, 5, 0),)))
    for n in range(ANSWERS_KEPT + COMERS):
        reply, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="a"), agent=f"ag{n}", request_id="r"), 0)
        assert reply.ok, reply.reason
        core.remove(reply.robot_id, "gone")
    assert len(core._answered) == ANSWERS_KEPT
    assert len(core.registry.entries) == 0
    last = RegisterRequest(spec=RobotSpecMsg(name="a"), agent=f"ag{ANSWERS_KEPT + COMERS - 1}", request_id="r")
    again, out = core.register(last, 0)
    assert again.ok
    assert out == []  # asked again: its first answer, nothing registered twice


def _sensors_view(ids: list[int]) -> WorldView:
    lab = Lab("t", 2000.0, 10.0, ())
    robots = [RobotSpecMsg(name=f"r{i}", id=i, x_m=1.0 + 0.5 * i, y_m=5.0) for i in ids]
    info = WorldInfo(revision=1, lab=LabMsg(name="t", width=2000.0, height=10.0), period_ns=100_000_000, robots=robots)
    return WorldView(info, Scene(lab), {r.id: spec_from_msg(r) for r in robots})


@pytest.mark.slow  # 2,000 ticks of the sensors node in process: about 3.5 s of CPU
def test_the_sensors_node_forgets_the_keys_of_robots_that_left() -> None:
    node = SensorsNode("t")
    for tick in range(1, 2000):
        ids = [1, 2, tick + 2]  # two robots stay, a third comes and goes every tick
        keys_out = [
            key
            for key, _ in node.on_state(
                world_state(tick, ids, x=[1.0 + 0.5 * i for i in ids], y=5.0), _sensors_view(ids)
            )
        ]
        assert len(keys_out) == 3
    assert sorted(node._keys) == [1, 2, 2001]


def test_the_viewer_feed_forgets_a_removed_robot_and_still_shows_its_removal() -> None:
    feed = Feed("t")
    for rid in range(1, COMERS):
        feed.on_event(make_event(EventKind.REGISTERED, RegisteredData(agent=f"a{rid}"), robot_id=rid))
        feed.on_readings(
            1,
            [
                SensorReading(
                    tick=1,
                    robot_id=rid,
                    proximity_ids=[0],
                    proximity_m=[1.0],
                    proximity_legacy=[0.0],
                    compass_deg=0.0,
                    gps=(0.0, 0.0, 0.0),
                )
            ],
        )
        feed.on_event(make_event(EventKind.WATCHDOG, robot_id=rid, reason="silent"))
        [shown] = feed.on_event(make_event(EventKind.REMOVED, robot_id=rid, reason="agent lost"))
        assert shown.robot_id == rid  # type: ignore[attr-defined]
    tables = (feed.readings, feed.agents, feed.events, feed.watchdog, feed._sent_prox)
    assert [len(t) for t in tables] == [0] * len(tables)


def _event(kind: EventKind, rid: int) -> Event:
    return make_event(kind, CollisionData(x=1.0, y=2.0) if kind == EventKind.COLLISION else None, robot_id=rid)


class _Pub:
    def __init__(self, key: str, undeclared: list[str]) -> None:
        self.key = key
        self._undeclared = undeclared

    def undeclare(self) -> None:
        self._undeclared.append(self.key)


def test_publishers_of_keys_gone_quiet_are_undeclared_and_those_in_use_kept() -> None:
    undeclared: list[str] = []
    pubs = Publishers(lambda key: _Pub(key, undeclared), capacity=64)
    for n in range(COMERS):
        pubs.get("robot/1/sensors")  # in use all along
        pubs.get(f"robot/{n + 2}/sensors")  # a robot that comes, publishes once and leaves
        assert len(pubs) <= 3 * 64  # used since the last sweep, and declared since
    assert "robot/1/sensors" not in undeclared
    assert len(undeclared) == len(set(undeclared)) == COMERS - (len(pubs) - 1)  # each quiet one given up, once
    first = pubs.get("robot/1/sensors")
    assert first is pubs.get("robot/1/sensors")  # declared once while in use


def test_publishers_all_in_use_beyond_the_capacity_are_all_kept() -> None:
    undeclared: list[str] = []
    pubs = Publishers(lambda key: _Pub(key, undeclared), capacity=8)
    live = [f"robot/{n}/sensors" for n in range(50)]
    for _ in range(3):
        for key in live:
            pubs.get(key)
    assert len(pubs) == 50
    assert undeclared == []


@pytest.mark.parametrize("kind", [EventKind.COLLISION, EventKind.WATCHDOG])
def test_a_robots_recent_events_are_a_bounded_history(kind: EventKind) -> None:
    feed = Feed("t")
    for _ in range(COMERS):
        feed.on_event(_event(kind, 7))
    assert 0 < len(feed.events[7]) <= 20


def test_legacy_viewers_that_come_and_go_leave_no_client_socket_or_muted_entry_behind() -> None:
    table = clients.ClientTable(FakeTransport())
    made: list[FakeTransport] = []
    for n in range(COMERS // 2):
        now = float(n)  # one new viewer a second, each silent after its reply
        table.expire(now)
        if table.full(now):
            continue
        t = FakeTransport()
        made.append(t)
        table.add(Viewer("viewer", ("127.0.0.1", 10_000 + n), t, since=now))
        table.mute(t, table.get(("127.0.0.1", 10_000 + n)), until=now + 1_000.0)  # over its budget, then gone
        assert len(table.by_peer) <= clients.MAX_VIEWERS
    live = len(table.by_peer)
    assert 0 < live <= clients.VIEWER_HANDSHAKE_S + 1
    assert len(table._muted) == live
    assert len(table.sel.get_map()) == 1  # the reception alone: every viewer's socket is muted or closed
    assert sum(t.closed for t in made) == len(made) - live  # each viewer let go took its socket with it
    table.close()
    assert all(t.closed for t in made)
