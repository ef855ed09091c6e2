from __future__ import annotations

from iw_zenoh.launch.tally import Tally
from iw_zenoh.messages import Event, EventKind, WorldState
from iw_zenoh.scenario.tables import Criteria, Reach


def _state(tick: int, x: float) -> WorldState:
    return WorldState(
        tick=tick,
        sim_time_ns=tick * 100_000_000,
        revision=0,
        ids=[1],
        x=[x],
        y=[0.0],
        heading=[0.0],
        collided=[False],
        rolled_left=[0.0],
        rolled_right=[0.0],
        speed=[0.0],
    )


def test_a_goal_is_noted_when_first_reached_and_judged() -> None:
    t = Tally()
    crit = Criteria(max_collisions=0, reach=(Reach(robot=1, x_m=5.0, y_m=0.0, within_m=0.5),))
    for tick, x in enumerate([0.0, 4.6, 5.0]):
        t.on_state(_state(tick, x), crit.reach)
    assert t.reached == {1: 0.1}
    ok, lines = t.verdict(crit)
    assert ok
    assert [line[:4] for line in lines] == ["PASS", "PASS"]


def test_collisions_and_holds_are_counted() -> None:
    t = Tally()
    t.on_event(Event(tick=1, sim_time_ns=0, kind=EventKind.COLLISION))
    t.on_event(Event(tick=1, sim_time_ns=0, kind=EventKind.HOLDING, reason="no collision process"))
    assert (t.collisions, t.holding) == (1, "no collision process")
    t.on_event(Event(tick=2, sim_time_ns=0, kind=EventKind.RESUMED))
    assert t.holding == ""
    ok, lines = t.verdict(Criteria(max_collisions=0))
    assert not ok
    assert lines == ["FAIL collisions 1 (at most 0)"]


def _registered(rid: int, agent: str) -> Event:
    from iw_zenoh.messages import RegisteredData, make_event

    return make_event(EventKind.REGISTERED, RegisteredData(agent=agent), reason="", robot_id=rid, source="world")


def test_the_status_counts_only_robots_whose_agent_is_alive() -> None:
    t = Tally()
    t.on_event(_registered(1, "driver"))
    t.on_state(_state(3, 1.0), ())
    t.agents_alive.add("driver")
    assert t.robots_alive() == 1
    assert "robots 1/1" in t.status(1.0, 1, 1)
    t.agents_alive.discard("driver")  # stopped: its token gone, its robot still in the world
    assert t.robots_alive() == 0
    line = t.status(1.0, 0, 1)
    assert "robots 0/1" in line
    assert "agents 0/1" in line


def test_the_snapshot_holds_the_last_state_the_roster_and_each_robots_agent() -> None:
    from iw_zenoh.messages import LabMsg, RobotSpecMsg, WorldInfo

    t = Tally()
    assert t.snapshot() is None  # nothing to resume from yet
    t.on_event(_registered(1, "driver"))
    t.on_event(Event(kind=EventKind.PAUSED, reason="", source="world"))
    t.on_state(_state(7, 2.5), ())
    t.info = WorldInfo(
        revision=4,
        lab=LabMsg(name="t", width=10.0, height=5.0),
        period_ns=100_000_000,
        robots=[RobotSpecMsg(name="a", id=1, x_m=1.0, y_m=0.5), RobotSpecMsg(name="b", id=2, x_m=3.0, y_m=0.5)],
    )
    snap = t.snapshot()
    assert snap is not None
    assert (snap.tick, snap.revision, snap.running) == (7, 4, False)
    assert [(r.spec.id, r.agent, r.pose) for r in snap.robots] == [(1, "driver", (2.5, 0.0, 0.0)), (2, "", None)]
