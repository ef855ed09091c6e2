"""The viewer's feed: the world's batched messages as page messages, only what changed."""

from __future__ import annotations

from typing import Any

import msgspec
import pytest

from iw_zenoh.messages import (
    CollisionData,
    Event,
    EventKind,
    LabMsg,
    LaserMsg,
    LaserScan,
    Obstacle,
    RobotSpecMsg,
    SensorBatch,
    SensorReading,
    Tick,
    WallMsg,
    WorldInfo,
    WorldState,
    make_event,
)
from iw_zenoh.messages.page import (
    PageCommand,
    PageEvent,
    PageFrame,
    PageReadings,
    PageScans,
    PageScene,
    PageStatus,
)
from iw_zenoh.viewer.feed import Feed, ScansWanted
from iw_zenoh.viewer.server import Scans
from tests.support.builders import world_state

WALL = WallMsg(corners=[(1.0, 1.0), (2.0, 1.0), (2.0, 2.0)], height=2.0)
OB = Obstacle(name="box", x0=5.0, y0=5.0, x1=6.0, y1=6.0)


def _info(revision: int, ids: list[int], obstacles: list[Obstacle] = []) -> WorldInfo:  # noqa: B006 - never mutated
    walls = [WALL] + [WallMsg(corners=[(o.x0, o.y0), (o.x1, o.y0), (o.x1, o.y1), (o.x0, o.y1)]) for o in obstacles]
    return WorldInfo(
        revision=revision,
        lab=LabMsg(name="lab", width=20.0, height=10.0, walls=walls),
        period_ns=100_000_000,
        robots=[RobotSpecMsg(name=f"r{i}", id=i, width_m=1.0, height_m=0.6, com=0.8) for i in ids],
        obstacles=obstacles,
    )


def _state(tick: int, ids: list[int], **kw: Any) -> WorldState:
    """The feed's tests' state: each robot at x = its id, a heading to round, moving."""
    return world_state(
        tick, ids, revision=0, x=[float(i) for i in ids], heading=0.123456789, rolled=0.1, speed=0.3, **kw
    )


def _reading(rid: int, front: float | None, tick: int = 1) -> SensorReading:
    return SensorReading(
        tick=tick,
        robot_id=rid,
        proximity_ids=[0, 1, 2, 3],
        proximity_m=[front, None, None, 2.0],
        proximity_legacy=[0.0] * 4,
        compass_deg=0.0,
        gps=(0.0, 0.0, 0.0),
    )


def test_a_scene_keeps_the_obstacles_apart_from_the_walls_and_gives_each_robot_its_outline() -> None:
    feed = Feed("t")
    [scene] = feed.on_info(_info(1, [1, 2], [OB]))
    assert isinstance(scene, PageScene)
    assert len(scene.walls) == 1
    assert scene.obstacles == [OB]
    r = scene.robots[0]
    assert r.outline[0] == pytest.approx((0.8, -0.3))  # the front right corner, 0.8 m ahead of the wheel axis
    assert [s.id for s in r.sensors] == [0, 1, 2, 3]
    assert feed.on_info(_info(1, [1, 2], [OB])) == []  # the same revision again: nothing new


def test_a_frame_names_the_robots_only_when_the_roster_changes() -> None:
    feed = Feed("t")
    [first] = feed.on_state(_state(1, [1, 2]), wall_ns=0)
    [second] = feed.on_state(_state(2, [1, 2]), wall_ns=1)
    [third] = feed.on_state(_state(3, [1]), wall_ns=2)
    assert isinstance(first, PageFrame)
    assert isinstance(second, PageFrame)
    assert isinstance(third, PageFrame)
    assert first.ids == [1, 2]
    assert second.ids is None
    assert third.ids == [1]
    assert first.heading == [0.1235, 0.1235]


def test_a_frame_colours_collided_watchdog_and_held_robots() -> None:
    feed = Feed("t")
    feed.on_event(make_event(EventKind.WATCHDOG, robot_id=2, reason="silent"))
    [f] = feed.on_state(_state(1, [1, 2, 3], collided=[True, False, False]), wall_ns=0)
    assert isinstance(f, PageFrame)
    assert f.state == "cwd"
    feed.on_event(make_event(EventKind.WATCHDOG_CLEARED, robot_id=2))
    [f] = feed.on_state(_state(2, [1, 2, 3], held=True, held_reason="no verdict"), wall_ns=1)
    assert isinstance(f, PageFrame)
    assert (f.state, f.held_reason) == ("hhh", "no verdict")
    [f] = feed.on_state(_state(3, [1, 2, 3]), wall_ns=2)
    assert isinstance(f, PageFrame)
    assert f.state == "ddd"


def test_readings_are_sent_only_when_they_move_by_a_centimetre_or_more() -> None:
    feed = Feed("t")
    feed.on_info(_info(1, [1, 2]))
    [r] = feed.on_sensors(SensorBatch(tick=1, shard="1-1", readings=[_reading(1, 1.0), _reading(2, None)]))
    assert isinstance(r, PageReadings)
    assert r.prox == {"1": [1.0, None, None, 2.0], "2": [None, None, None, 2.0]}
    assert feed.on_sensors(SensorBatch(tick=2, shard="1-1", readings=[_reading(1, 1.004), _reading(2, None)])) == []
    [r] = feed.on_sensors(SensorBatch(tick=3, shard="1-1", readings=[_reading(1, 1.004), _reading(2, 3.0)]))
    assert isinstance(r, PageReadings)
    assert r.prox == {"2": [3.0, None, None, 2.0]}


def test_an_event_is_placed_at_its_collision_point_or_at_its_robot() -> None:
    feed = Feed("t")
    feed.on_state(_state(1, [4]), wall_ns=0)
    [hit] = feed.on_event(make_event(EventKind.COLLISION, CollisionData(x=3.5, y=2.5), robot_id=4))
    [gone] = feed.on_event(make_event(EventKind.WATCHDOG, robot_id=4))
    [nowhere] = feed.on_event(Event(kind=EventKind.PAUSED))
    assert isinstance(hit, PageEvent)
    assert isinstance(gone, PageEvent)
    assert isinstance(nowhere, PageEvent)
    assert (hit.where, gone.where, nowhere.where) == ((3.5, 2.5), (4.0, 1.0), None)
    assert [e["kind"] for e in feed.reading(4).events] == ["collision", "watchdog"]


def test_a_robots_reading_has_its_agent_motors_speed_and_pose() -> None:
    feed = Feed("t")
    feed.on_info(_info(1, [1]))
    feed.on_event(Event(kind=EventKind.REGISTERED, robot_id=1, data={"agent": "host-1"}))
    feed.on_state(_state(5, [1]), wall_ns=0)
    feed.on_sensors(SensorBatch(tick=5, shard="1-1", readings=[_reading(1, 0.5, tick=5)]))
    got = feed.reading(1)
    assert got.reading is not None
    assert got.reading["agent"] == "host-1"
    assert got.reading["proximity_m"][0] == 0.5
    assert (got.speed, got.motors, got.pose) == (0.3, (0.1, 0.1), (1.0, 1.0, 0.123456789))
    assert feed.reading(99).reading is None


def test_the_clock_is_sent_when_it_pauses_and_then_not_again_until_it_changes() -> None:
    feed = Feed("t")
    [s] = feed.on_tick(Tick(tick=1, period_ns=100, running=True), wall_ns=0)
    assert isinstance(s, PageStatus)
    assert s.running
    assert feed.on_tick(Tick(tick=2, period_ns=100, running=True), wall_ns=1_000) == []
    [s] = feed.on_tick(Tick(tick=2, period_ns=100, running=False), wall_ns=2_000)
    assert isinstance(s, PageStatus)
    assert not s.running
    assert feed.on_tick(Tick(tick=2, period_ns=100, running=False), wall_ns=3_000) == []


def test_a_snapshot_gives_a_joining_page_the_scene_clock_frame_with_ids_and_readings() -> None:
    feed = Feed("t")
    feed.on_info(_info(1, [1]))
    feed.on_tick(Tick(tick=1, period_ns=100), wall_ns=0)
    feed.on_state(_state(1, [1]), wall_ns=0)
    feed.on_state(_state(2, [1]), wall_ns=1)
    feed.on_sensors(SensorBatch(tick=2, shard="1-1", readings=[_reading(1, 0.5)]))
    kinds = [type(m).__name__ for m in feed.snapshot(wall_ns=2)]
    assert kinds == ["PageScene", "PageStatus", "PageFrame", "PageReadings"]
    frame = feed.snapshot(wall_ns=2)[2]
    assert isinstance(frame, PageFrame)
    assert frame.ids == [1]


def test_an_older_revision_is_a_new_scene_too_a_replay_sought_back() -> None:
    feed = Feed("t")
    feed.on_info(_info(3, [1, 2]))
    assert feed.needs_info(2)
    [scene] = feed.on_info(_info(2, [1]))
    assert isinstance(scene, PageScene)
    assert [r.id for r in scene.robots] == [1]
    assert not feed.needs_info(2)


def test_a_late_viewer_knows_each_robots_agent_from_the_worlds_description() -> None:
    feed = Feed("t")
    info = msgspec.structs.replace(_info(1, [1, 2]), agents=["host-1", ""])
    [scene] = feed.on_info(info)
    assert isinstance(scene, PageScene)
    assert [r.agent for r in scene.robots] == ["host-1", ""]
    feed.on_state(_state(1, [1, 2]), wall_ns=0)
    feed.on_sensors(SensorBatch(tick=1, shard="1-1", readings=[_reading(1, 0.5)]))
    got = feed.reading(1).reading
    assert got is not None
    assert got["agent"] == "host-1"  # no registered event seen


def test_an_older_description_without_agents_keeps_the_agent_its_registered_event_named() -> None:
    feed = Feed("t")
    feed.on_event(Event(kind=EventKind.REGISTERED, robot_id=1, data={"agent": "host-1"}))
    [scene] = feed.on_info(_info(1, [1]))
    assert isinstance(scene, PageScene)
    assert scene.robots[0].agent == "host-1"


def _scanner_info() -> WorldInfo:
    laser = LaserMsg(id=3, x_m=0.5, fov_deg=180.0, beams=3, range_m=5.0)
    robots = [RobotSpecMsg(name="scan", id=1, lasers=[laser]), RobotSpecMsg(name="plain", id=2)]
    return WorldInfo(revision=1, lab=LabMsg(name="lab", width=20.0, height=10.0), period_ns=1, robots=robots)


def _scanned(rid: int, ranges: list[float | None], tick: int = 1) -> SensorReading:
    r = _reading(rid, None, tick)
    return msgspec.structs.replace(r, lasers=[LaserScan(id=3, ranges=ranges)])


def test_a_scanners_place_and_its_scans_reach_the_page_only_when_they_move() -> None:
    feed = Feed("t")
    [scene] = feed.on_info(_scanner_info())
    assert isinstance(scene, PageScene)
    [laser] = scene.robots[0].lasers
    assert (laser.id, laser.x, laser.fov_deg, laser.beams, laser.range_m) == (3, 0.5, 180.0, 3, 5.0)
    assert scene.robots[1].lasers == []
    out = feed.on_sensors(SensorBatch(tick=1, shard="1-1", readings=[_scanned(1, [1.234, None, 4.0]), _reading(2, 1)]))
    [scans] = [m for m in out if isinstance(m, PageScans)]
    assert scans.scans == {"1": [[1.23, None, 4.0]]}  # only the robot with a scanner
    again = feed.on_sensors(SensorBatch(tick=2, shard="1-1", readings=[_scanned(1, [1.232, None, 4.0], 2)]))
    assert not [m for m in again if isinstance(m, PageScans)]  # moved by less than a centimetre
    [moved] = feed.on_sensors(SensorBatch(tick=3, shard="1-1", readings=[_scanned(1, [1.234, 2.0, 4.0], 3)]))
    assert isinstance(moved, PageScans)
    assert moved.scans == {"1": [[1.23, 2.0, 4.0]]}
    feed.on_state(_state(3, [1, 2]), wall_ns=0)
    [snap] = [m for m in feed.snapshot(wall_ns=0) if isinstance(m, PageScans)]
    assert snap.scans == {"1": [[1.23, 2.0, 4.0]]}  # a page that joins sees the last scan


def _wanted(scans: str, robot_id: int = 0) -> ScansWanted:
    return ScansWanted.of(
        msgspec.json.decode(
            msgspec.json.encode({"cmd": "scans", "scans": scans, "robot_id": robot_id}), type=PageCommand
        )
    )


def test_a_page_is_sent_the_scans_of_every_robot_of_the_one_it_selected_or_none() -> None:
    msg = PageScans(tick=4, scans={"1": [[1.0, None]], "2": [[2.0, 3.0]]})
    assert ScansWanted().keep(msg) is msg  # a page that never said: every robot's, as before
    assert _wanted("all", 2).keep(msg) is msg
    assert _wanted("selected", 2).keep(msg) == PageScans(tick=4, scans={"2": [[2.0, 3.0]]})
    assert _wanted("selected", 0).keep(msg) is None  # robot 0 is selected: its scans did not change
    assert _wanted("none", 2).keep(msg) is None
    one = Scans(msg)
    assert msgspec.json.decode(one.for_page(_wanted("selected", 1)) or "") == {
        "type": "scans",
        "tick": 4,
        "scans": {"1": [[1.0, None]]},
    }
    assert one.for_page(_wanted("none")) is None
    assert msgspec.json.decode(one.for_page(ScansWanted()) or "")["scans"].keys() == {"1", "2"}


def test_a_page_that_draws_more_scans_is_given_the_last_ones_sent() -> None:
    feed = Feed("t")
    assert feed.scans_now() is None
    feed.on_info(_scanner_info())
    feed.on_sensors(SensorBatch(tick=1, shard="1-1", readings=[_scanned(1, [1.0, None, 4.0]), _reading(2, 1)]))
    feed.on_sensors(SensorBatch(tick=2, shard="1-1", readings=[_scanned(1, [1.001, None, 4.0], 2)]))  # not sent
    feed.on_state(_state(2, [1, 2]), wall_ns=0)
    assert feed.scans_now() == PageScans(tick=2, scans={"1": [[1.0, None, 4.0]]})
    [snap] = [m for m in feed.snapshot(wall_ns=0) if isinstance(m, PageScans)]
    assert snap == feed.scans_now()
