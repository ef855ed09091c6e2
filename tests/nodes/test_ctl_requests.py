"""What ``iwz ctl``'s words ask the world, and which events answer them."""

from __future__ import annotations

import pytest

from iw_zenoh.messages import EventKind, Obstacle, ObstacleData, make_event
from iw_zenoh.nodes.ctl_requests import answer_to, parse_request, resolve_move


@pytest.mark.parametrize(
    ("command", "words", "control"),
    [
        ("pause", [], "pause"),
        ("resume", [], "start"),
        ("start", [], "start"),
        ("stop", [], "stop"),
        ("step", [], "step"),
        ("remove", ["3"], "remove"),
        ("obstacle", ["add", "A", "1,2,3,4"], "add_obstacle"),
        ("obstacle", ["move", "A", "1,2"], "move_obstacle"),
        ("obstacle", ["remove", "A"], "remove_obstacle"),
    ],
)
def test_each_command_becomes_its_control(command: str, words: list[str], control: str) -> None:
    assert parse_request(command, words).control.command == control


def test_step_takes_a_count_and_remove_an_id() -> None:
    assert parse_request("step", ["7"]).control.steps == 7
    assert parse_request("step", []).control.steps == 1
    assert parse_request("remove", ["12"]).control.robot_id == 12


def test_an_obstacle_takes_its_corners_and_a_height() -> None:
    ob = parse_request("obstacle", ["add", "A", "1,2,3,4"]).control.obstacle
    assert ob == Obstacle(name="A", x0=1, y0=2, x1=3, y1=4, height=1.0)
    assert parse_request("obstacle", ["add", "A", "1,2,3,4,2.5"]).control.obstacle.height == 2.5  # type: ignore[union-attr]
    assert parse_request("obstacle", ["add", "A", "1,2,3,4"], height_m=0.4).control.obstacle.height == 0.4  # type: ignore[union-attr]


@pytest.mark.parametrize(
    ("command", "words", "says"),
    [
        ("pause", ["now"], "pause takes nothing more"),
        ("step", ["0"], "step takes one count N >= 1"),
        ("step", ["two"], "step takes one count N >= 1"),
        ("remove", [], "remove takes one robot ID"),
        ("remove", ["-1"], "remove takes one robot ID"),
        ("obstacle", ["paint", "A"], "obstacle takes add, move or remove"),
        ("obstacle", ["add", "A", "1,2"], "expected 4 or 5 numbers"),
        ("obstacle", ["add", "A"], "obstacle add takes NAME X0,Y0,X1,Y1"),
        ("obstacle", ["move", "A", "x,y"], "expected 2 or 4 or 5 numbers"),
        ("obstacle", ["remove"], "obstacle remove takes one NAME"),
        ("fly", [], "no command 'fly'"),
        ("step", [str(2**63)], "step takes one count N >= 1"),
        ("remove", [str(2**64)], "remove takes one robot ID"),
        ("obstacle", ["add", "A", "nan,2,3,4"], "4 or 5 numbers separated by commas, each finite"),
        ("obstacle", ["add", "A", "1,2,3,inf"], "4 or 5 numbers separated by commas, each finite"),
        ("obstacle", ["move", "A", "nan,2"], "2 or 4 or 5 numbers separated by commas, each finite"),
        ("obstacle", ["add", "A", "1,2,3,4,-1"], "height is a positive number"),
        ("obstacle", ["add", "", "1,2,3,4"], "a NAME that is not empty"),
    ],
)
def test_a_bad_command_line_says_what_the_command_takes(command: str, words: list[str], says: str) -> None:
    with pytest.raises(ValueError, match=says):
        parse_request(command, words)


@pytest.mark.parametrize("height", [-1.0, 0.0, float("nan"), float("inf")])
def test_a_height_that_is_no_positive_number_is_refused_before_anything_is_sent(height: float) -> None:
    with pytest.raises(ValueError, match="height is a positive number"):
        parse_request("obstacle", ["add", "A", "1,2,3,4"], height_m=height)


def test_a_move_to_a_centre_keeps_the_size_and_height() -> None:
    req = parse_request("obstacle", ["move", "A", "10,5"])
    now = {"A": Obstacle(name="A", x0=1, y0=1, x1=2, y1=3, height=0.7)}
    moved = resolve_move(req, now).control.obstacle
    assert moved == Obstacle(name="A", x0=9.5, y0=4.0, x1=10.5, y1=6.0, height=0.7)
    assert resolve_move(req, now, height_m=2.0).control.obstacle.height == 2.0  # type: ignore[union-attr]
    with pytest.raises(ValueError, match="no obstacle named 'B' to move \\(the world has 'A'\\)"):
        resolve_move(parse_request("obstacle", ["move", "B", "1,1"]), now)


def test_the_answer_is_the_commands_own_event_or_a_refusal_about_it() -> None:
    pause = parse_request("pause", [])
    assert (
        answer_to(pause, make_event(EventKind.PAUSED, reason="simulation paused", tick=9, source="world")) is not None
    )
    assert answer_to(pause, make_event(EventKind.STARTED, source="world")) is None
    assert answer_to(pause, make_event(EventKind.PAUSED, source="replay/r")) is None  # not the world
    remove = parse_request("remove", ["2"])
    assert answer_to(remove, make_event(EventKind.REMOVED, robot_id=3, source="world")) is None
    done = answer_to(remove, make_event(EventKind.REMOVED, robot_id=2, tick=4, source="world"))
    assert done is not None
    assert done.ok
    assert done.tick == 4
    refused = answer_to(remove, make_event(EventKind.BAD_CONTROL, reason="no robot 2", robot_id=2, source="world"))
    assert refused is not None
    assert not refused.ok
    add = parse_request("obstacle", ["add", "A", "1,2,3,4"])
    other = make_event(EventKind.OBSTACLE, ObstacleData(name="B"), reason="add_obstacle 'B'", source="world")
    assert answer_to(add, other) is None
    mine = make_event(EventKind.OBSTACLE, ObstacleData(name="A"), reason="add_obstacle 'A'", source="world")
    assert answer_to(add, mine) is not None
    assert answer_to(add, make_event(EventKind.BAD_CONTROL, reason="obstacle 'B': off the map", source="world")) is None
    assert not answer_to(add, make_event(EventKind.BAD_CONTROL, reason="obstacle 'A': off", source="world")).ok  # type: ignore[union-attr]
