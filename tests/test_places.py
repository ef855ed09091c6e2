"""Every agent program reads --start, --goal, --waypoints and --at with one parser: the same
errors, the same form, whichever program it is."""

from __future__ import annotations

import argparse
import importlib

import pytest

from iw_zenoh.agent.places import (
    BOXES_FORM,
    POINT_FORM,
    POINTS_FORM,
    POSE_FORM,
    parse_boxes,
    parse_point,
    parse_points,
    parse_pose,
)
from iw_zenoh.core.lab import Wall


def test_a_pose_a_point_and_waypoints_are_read() -> None:
    assert parse_pose(" 1.5, 3,-90") == (1.5, 3.0, -90.0)
    assert parse_point("10.5,3") == (10.5, 3.0)
    assert parse_points("16,5.55;;21.5,6.5;") == [(16.0, 5.55), (21.5, 6.5)]


def test_boxes_are_read_as_one_metre_walls_and_a_bad_one_is_named() -> None:
    assert parse_boxes("") == ()
    assert parse_boxes("4,2,5,4;; 8,1,9,2") == (
        Wall(((4.0, 2.0), (5.0, 2.0), (5.0, 4.0), (4.0, 4.0)), 1.0),
        Wall(((8.0, 1.0), (9.0, 1.0), (9.0, 2.0), (8.0, 2.0)), 1.0),
    )
    with pytest.raises(ValueError, match="box 2, '8,1,9': 3 numbers") as e:
        parse_boxes("4,2,5,4;8,1,9")
    assert str(e.value).startswith(BOXES_FORM)


@pytest.mark.parametrize(
    ("parse", "text", "form", "why"),
    [
        (parse_pose, "1,2", POSE_FORM, "2 numbers"),
        (parse_pose, "1,2,east", POSE_FORM, "'east' is not a number"),
        (parse_pose, "1,nan,0", POSE_FORM, "'nan' is not a finite number"),
        (parse_point, "1", POINT_FORM, "1 number)"),
        (parse_point, "1,2,3", POINT_FORM, "3 numbers"),
        (parse_points, " ; ", POINTS_FORM, "no point"),
        (parse_points, "1,2;3", POINTS_FORM, "point 2, '3': 1 number"),
    ],
)
def test_a_bad_place_says_the_form_and_what_is_wrong(parse, text: str, form: str, why: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match="; got ") as e:
        parse(text)
    assert form in str(e.value)
    assert why in str(e.value)
    assert f"; got {text!r} (" in str(e.value)


@pytest.mark.parametrize(
    ("program", "argv", "flag", "form"),
    [
        ("wheelchair", ["--map", "m.xml", "--start", "1,2", "--goal", "3,4"], "--start", POSE_FORM),
        ("wheelchair", ["--map", "m.xml", "--start", "1,2,0", "--goal", "3;4"], "--goal", POINT_FORM),
        ("waypoint", ["--waypoints", "1,2;3,4", "--start", "1,2,x"], "--start", POSE_FORM),
        ("waypoint", ["--waypoints", "1,2;3"], "--waypoints", POINTS_FORM),
        ("convoy", ["--role", "leader", "--waypoints", "1"], "--waypoints", POINTS_FORM),
        ("door", ["--at", "10,5.5"], "--at", POSE_FORM),
    ],
)
def test_every_program_refuses_a_bad_place_in_the_same_words(
    program: str, argv: list[str], flag: str, form: str, capsys: pytest.CaptureFixture[str]
) -> None:
    parser = argparse.ArgumentParser(prog=f"iwz agent {program}")
    importlib.import_module(f"iw_zenoh.agents.{program}").add_arguments(parser)
    with pytest.raises(SystemExit) as e:
        parser.parse_args(argv)
    assert e.value.code == 2
    assert f"error: argument {flag}: {form}; got " in capsys.readouterr().err
