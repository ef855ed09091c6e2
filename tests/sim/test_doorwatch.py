from __future__ import annotations

import math

from iw_zenoh.launch.tally import Tally
from iw_zenoh.messages import WorldState
from iw_zenoh.scenario.tables import Criteria, DoorCriterion
from iw_zenoh.sim.doorwatch import DoorWatch

HINGED = DoorCriterion(robot=1, x_m=10.0, y_m=5.0, one_chair_within_m=1.0)


def _watch(crit: DoorCriterion, track: list[dict[int, tuple[float, float, float]]]) -> DoorWatch:
    w = DoorWatch()
    for i, poses in enumerate(track):
        w.observe((crit,), i * 0.1, poses, set())
    return w


def _hinged(deg: float, chair_x: float = 4.0) -> dict[int, tuple[float, float, float]]:
    return {1: (10.0, 5.5, math.radians(deg)), 2: (chair_x, 5.0, 0.0)}


def test_a_door_that_opens_and_closes_again_passes() -> None:
    track = [_hinged(-90.0), _hinged(-40.0), _hinged(0.0, 10.0), _hinged(-60.0), _hinged(-88.0), _hinged(-88.0)]
    w = _watch(HINGED, track)
    ok, lines = w.verdict((HINGED,))
    assert ok, lines
    assert lines == [
        "PASS door 1 opened at t=0.1 s",
        "PASS door 1 closed again at t=0.5 s",  # back, and still
        "PASS door 1: never two chairs within 1 m of (10, 5)",
    ]
    assert w.settled((HINGED,))


def test_a_door_that_never_opens_fails_and_so_does_the_run() -> None:
    t = Tally()
    crit = Criteria(max_collisions=0, doors=(HINGED,))
    for tick in range(5):
        st = WorldState(
            tick=tick,
            sim_time_ns=tick * 100_000_000,
            revision=0,
            ids=[1, 2],
            x=[10.0, 4.0 + tick],
            y=[5.5, 5.0],
            heading=[-math.pi / 2, 0.0],
            collided=[False, False],
            rolled_left=[0.0, 0.0],
            rolled_right=[0.0, 0.0],
            speed=[0.0, 0.0],
        )
        t.on_state(st, crit.reach, crit.doors)
    ok, lines = t.verdict(crit)
    assert not ok
    assert "FAIL door 1 opened: it never did" in lines
    assert "FAIL door 1 closed again: it never did" in lines
    assert not t.doors.settled(crit.doors)  # a run that stops on its goals waits for the door


def test_a_door_left_open_fails_closed_again() -> None:
    w = _watch(HINGED, [_hinged(-90.0), _hinged(-30.0), _hinged(0.0)])
    ok, lines = w.verdict((HINGED,))
    assert not ok
    assert "FAIL door 1 closed again: it never did" in lines


def test_two_chairs_in_the_doorway_at_once_fail_naming_them_and_when() -> None:
    both = {**_hinged(0.0, 9.5), 3: (10.6, 5.2, math.pi)}
    w = _watch(HINGED, [_hinged(-90.0), _hinged(0.0, 9.5), both, _hinged(-90.0, 11.0)])
    ok, lines = w.verdict((HINGED,))
    assert not ok
    assert "FAIL door 1: chairs 2, 3 within 1 m of (10, 5) at t=0.2 s" in lines


def test_other_doors_are_not_chairs() -> None:
    crit = DoorCriterion(robot=1, opened=False, closed_again=False, x_m=10.0, y_m=5.0, one_chair_within_m=1.0)
    w = DoorWatch()
    w.observe((crit,), 0.0, {1: (10.0, 5.0, 0.0), 2: (10.2, 5.0, 0.0), 7: (10.5, 5.0, 0.0)}, {7})
    assert w.verdict((crit,))[0]  # robot 7 is a door (the world's Door type): one chair only


def test_a_revolving_door_half_turn_opens_and_closes_it_modulo_its_symmetry() -> None:
    crit = DoorCriterion(robot=1, symmetry_deg=90.0)
    turns = [0.0, 30.0, 60.0, 90.0, 120.0, 179.0, -170.0, 180.0, 180.0]  # through +-180: unwrapped, 180 in all
    w = _watch(crit, [{1: (10.0, 5.0, math.radians(d))} for d in turns])
    ok, lines = w.verdict((crit,))
    assert ok, lines
    assert lines[0] == "PASS door 1 opened at t=0.2 s"  # turned 60 degrees: past 45
    assert lines[1] == "PASS door 1 closed again at t=0.8 s"  # at rest a half turn on (four wings: every 90)


def test_a_revolving_door_turning_past_a_shut_angle_is_not_closed() -> None:
    crit = DoorCriterion(robot=1, symmetry_deg=60.0)
    turns = [0.0, 20.0, 50.0, 60.0, 70.0, 100.0]  # past 60 on the way: it never stood there
    w = _watch(crit, [{1: (10.0, 5.0, math.radians(d))} for d in turns])
    assert "FAIL door 1 closed again: it never did" in w.verdict((crit,))[1]


def test_a_sliding_door_opens_by_moving_along_its_wall() -> None:
    crit = DoorCriterion(robot=1)
    ys = [5.0, 5.3, 5.7, 6.2, 5.6, 5.03, 5.03]
    w = _watch(crit, [{1: (10.0, y, math.pi / 2)} for y in ys])
    assert w.verdict((crit,)) == (True, ["PASS door 1 opened at t=0.2 s", "PASS door 1 closed again at t=0.6 s"])
