"""A revolving door and a chair passing it, their logic in one loop: no world, no radio."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from iw_zenoh.agents.passage import Arbiter, Ask, In, Passed, Turn, parse, parse_all
from iw_zenoh.agents.revolving import HOLD_S, Phase, RevolvingDoor, RevolvingPilot, leaves, mid_wheel_chair
from iw_zenoh.agents.waypoint import fine_chair

from iw_zenoh.core.geometry import rect_outline, to_world
from iw_zenoh.core.revolving import Drum, drum_walls

DRUM = Drum(10.0, 5.0, axis_deg=0.0, radius_m=1.6, wings=3)
DT = 0.1


def _door() -> RevolvingDoor:
    door = RevolvingDoor(DRUM, DT)
    door.arbiter = Arbiter(1, hold_s=HOLD_S)
    return door


def _run_door(door: RevolvingDoor, ticks: range, heard: list[object]) -> list[str]:
    """Runs the door; it hears ``heard`` at the first tick and every second after (a chair asks
    once a second)."""
    said = []
    for tick in ticks:
        door.advance(tick, collided=False)
        text = door.talk(tick * DT, heard if (tick - ticks.start) % 10 == 0 else [])  # type: ignore[arg-type]
        said += [text] if text else []
    return said


def test_the_door_turns_a_sector_to_face_a_chair_from_the_far_side_before_it_grants() -> None:
    door = _door()
    said = _run_door(door, range(0, 5), [Ask(1, 4, 0.0, 1, side=-1)])
    assert said[0] == "WAIT 1 4 0 1"  # a leaf faces it: not yet
    assert door.span_deg == 60.0  # half a sector, so that a sector does
    said = _run_door(door, range(5, 70), [Ask(1, 4, 0.0, 2, side=-1)])
    assert (door.rest_deg, door.span_deg) == (60.0, 0.0)
    assert said[-1] == "GRANT 1 4 2"
    assert door.phase == Phase.WAIT_IN


def test_granted_and_in_the_door_carries_the_chair_half_a_turn_and_serves_the_next_once_it_passed() -> None:
    door = _door()
    _run_door(door, range(0, 2), [Ask(1, 4, 0.0, 1, side=1)])
    _run_door(door, range(2, 3), [In(1, 4)])
    assert door.phase == Phase.CARRY
    turns = [parse(t.split(";")[-1]) for t in _run_door(door, range(4, 300), [Ask(1, 4, 0.0, 1, side=1)])]
    done = [t.done_deg for t in turns if isinstance(t, Turn)]
    assert done == sorted(done)  # always on, never back
    assert done[-1] == 180.0
    assert door.phase == Phase.DELIVERED
    _run_door(door, range(300, 302), [Passed(1, 4)])
    assert door.phase == Phase.IDLE
    assert door.arbiter is not None
    assert door.arbiter.holder is None


def test_a_leaf_that_touches_something_holds_the_whole_door() -> None:
    door = _door()
    door.span_deg, door.span_s = 180.0, 24.0
    door.advance(1, collided=False)
    before = door.elapsed_s
    door.advance(2, collided=True)
    door.advance(3, collided=False)
    assert door.elapsed_s == before


def test_the_protocol_texts_read_back() -> None:
    for m in (Ask(1, 4, 2.5, 3, side=-1), In(1, 4), Turn(1, 4, 37.25, 7.5, 12.3)):
        assert parse(m.text()) == m
    assert parse("ASK 1 4 2.5 3 7") is None  # a side is +1 or -1


def _outline(size: tuple[float, float, float], pose: tuple[float, float, float]) -> shapely.Polygon:
    w, h, com = size
    c = rect_outline(np.array([w]), np.array([h]), np.array([com]))
    return shapely.Polygon(to_world(c, np.array([pose[0]]), np.array([pose[1]]), np.array([math.radians(pose[2])]))[0])


@pytest.mark.parametrize(("start", "side"), [((5.5, 5.0, 0.0), 1), ((14.5, 5.3, 180.0), -1)])
def test_a_chair_and_the_door_pass_it_through_in_one_loop_touching_nothing(
    start: tuple[float, float, float], side: int
) -> None:
    door = _door()
    [leaf, *_] = leaves("door", DRUM)
    leaf_size = (leaf.spec().width_m, leaf.spec().height_m, leaf.spec().com)
    spec = mid_wheel_chair(fine_chair("chair"))
    pilot = RevolvingPilot(DRUM, 1, spec)
    pilot.on_registered(4)
    walls = [shapely.Polygon(w) for w in drum_walls(DRUM)]
    pose, to_door, nearest = start, "", math.inf
    for tick in range(4000):
        door.advance(tick, collided=False)
        said = door.talk(tick * DT, parse_all(to_door)) or ""
        if not pilot.engaged(pose[0], pose[1]):
            break
        cmd = pilot.step(tick * DT, pose, parse_all(said))
        to_door = cmd.say or ""
        vl, vr = (p / 0.15 * spec.max_speed_mps for p in (cmd.left, cmd.right))  # exact motors
        v, w = 0.5 * (vl + vr), (vr - vl) / spec.height_m
        h = math.radians(pose[2]) + 0.5 * w * DT
        pose = (pose[0] + v * DT * math.cos(h), pose[1] + v * DT * math.sin(h), pose[2] + math.degrees(w * DT))
        turn = door.turn()[0]
        chair = _outline((1.0, 0.6, 0.5), pose)
        things = [_outline(leaf_size, (10.0, 5.0, DRUM.leaf_heading_deg(k, turn))) for k in range(3)] + walls
        nearest = min(nearest, *(chair.distance(t) for t in things))
    assert pilot.stage == "done"
    assert (pose[0] - 10.0) * side > DRUM.radius_m  # out on the other side
    assert nearest > 0.05  # it never touched a leaf or the drum
    assert pilot.farewell(tick * DT) == "PASSED 1 4"
