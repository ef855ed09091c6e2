from __future__ import annotations

import pytest
from iw_zenoh.agents.door import DoorKind, DoorMachine, DoorParams, DoorState

CLOSED = (5.0, 5.0, 0.0)


def _machine(kind: DoorKind = DoorKind.HINGED, timeout: float = 1.0) -> DoorMachine:
    return DoorMachine(DoorParams(kind=kind, timeout_s=timeout), CLOSED)


def test_closed_stays_closed_until_something_is_detected() -> None:
    m = _machine()
    assert m.step(detected=False, collided=False, pose=CLOSED, dt_s=0.1) == (0.0, 0.0)
    assert m.state == DoorState.CLOSED
    left, right = m.step(detected=True, collided=False, pose=CLOSED, dt_s=0.1)
    assert m.state == DoorState.OPENING
    assert left == -right != 0.0  # a hinged door turns: left = -right


def test_opening_ends_open_after_90_degrees_and_the_timer_closes_it() -> None:
    m = _machine(timeout=0.3)
    m.step(detected=True, collided=False, pose=CLOSED, dt_s=0.1)
    m.step(detected=False, collided=False, pose=(5.0, 5.0, 45.0), dt_s=0.1)
    assert m.state == DoorState.OPENING
    assert m.step(detected=False, collided=False, pose=(5.0, 5.0, 90.0), dt_s=0.1) == (0.0, 0.0)
    assert m.state == DoorState.OPEN
    for _ in range(2):
        m.step(detected=False, collided=False, pose=(5.0, 5.0, 90.0), dt_s=0.1)
    assert m.state == DoorState.OPEN
    left, right = m.step(detected=False, collided=False, pose=(5.0, 5.0, 90.0), dt_s=0.1)
    assert m.state == DoorState.CLOSING
    assert (left, right) == (0.05, -0.05)  # turning back
    m.step(detected=False, collided=False, pose=(5.0, 5.0, 0.5), dt_s=0.1)
    assert m.state == DoorState.CLOSED


def test_detection_while_open_restarts_the_timer() -> None:
    m = _machine(timeout=0.25)
    m.state = DoorState.OPEN
    open_pose = (5.0, 5.0, 90.0)
    m.step(detected=False, collided=False, pose=open_pose, dt_s=0.2)
    m.step(detected=True, collided=False, pose=open_pose, dt_s=0.2)
    m.step(detected=False, collided=False, pose=open_pose, dt_s=0.2)
    assert m.state == DoorState.OPEN


@pytest.mark.parametrize("state", [DoorState.OPENING, DoorState.CLOSING])
def test_a_collision_stops_the_movement_and_it_resumes_when_clear(state: DoorState) -> None:
    m = _machine()
    m.state = state
    half = (5.0, 5.0, 45.0)
    assert m.step(detected=False, collided=True, pose=half, dt_s=0.1) == (0.0, 0.0)
    assert m.state == state
    assert m.step(detected=False, collided=False, pose=half, dt_s=0.1) != (0.0, 0.0)


def test_something_detected_while_closing_opens_it_again() -> None:
    m = _machine()
    m.state = DoorState.CLOSING
    m.step(detected=True, collided=False, pose=(5.0, 5.0, 30.0), dt_s=0.1)
    assert m.state == DoorState.OPENING


def test_a_sliding_door_slides_its_length() -> None:
    m = _machine(DoorKind.SLIDING)
    left, right = m.step(detected=True, collided=False, pose=CLOSED, dt_s=0.1)
    assert left == right > 0.0  # sliding: left = right
    m.step(detected=False, collided=False, pose=(6.0, 5.0, 0.0), dt_s=0.1)
    assert m.state == DoorState.OPEN


def test_a_revolving_door_turns_while_detected_and_stops_after_the_timeout() -> None:
    m = _machine(DoorKind.REVOLVING, timeout=0.2)
    assert m.step(detected=True, collided=False, pose=CLOSED, dt_s=0.1) == (-0.05, 0.05)
    assert m.step(detected=False, collided=False, pose=CLOSED, dt_s=0.1) == (-0.05, 0.05)
    m.step(detected=False, collided=False, pose=CLOSED, dt_s=0.1)
    assert m.step(detected=False, collided=False, pose=CLOSED, dt_s=0.1) == (0.0, 0.0)


def test_a_sliding_leaf_lies_along_its_heading_and_slides_its_whole_length() -> None:
    import argparse

    from iw_zenoh.agents import door

    p = argparse.ArgumentParser()
    door.add_arguments(p)
    [agent] = door.make(p.parse_args(["--kind", "sliding", "--at", "10,5,90", "--leaf", "1.2"]))
    spec = agent.spec()
    assert (spec.width_m, spec.com) == (1.2, 0.5)  # the leaf's length along the way it slides
    assert spec.height_m < 0.1  # thinner than a wall: it hides in the wall beside the doorway
    assert agent.machine.p.slide_m == 1.2  # so the doorway it covered is clear when open
    assert all(abs(s.y_m) >= 0.1 for s in spec.ir_sensors)  # its sensors stay out of the wall, open or closed
