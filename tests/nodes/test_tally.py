from __future__ import annotations

from iw_zenoh.config import Criteria, Reach
from iw_zenoh.messages import Event, EventKind, WorldState
from iw_zenoh.nodes.tally import Tally


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
    crit = Criteria(max_collisions=0, reach=(Reach(robot=1, x=5.0, y=0.0, within=0.5),))
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
