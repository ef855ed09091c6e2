"""Places as agent programs take them on their command lines: a pose (``--start``, ``--at``), a
point (``--goal``), a list of points (``--waypoints``), boxes of a room (``--room``), read by one
parser so every program's errors read alike.

The ``*_arg`` functions are argparse ``type=`` converters: a bad value ends the program with
``iwz agent PROGRAM: error: argument --start: a pose is x,y,dir_deg ... got '1,2'`` (exit 2).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

if TYPE_CHECKING:
    from iw_zenoh.core.lab import Wall

__all__ = [
    "BOX_HEIGHT_M",
    "parse_boxes",
    "parse_point",
    "parse_points",
    "parse_pose",
    "point_arg",
    "points_arg",
    "pose_arg",
]

T = TypeVar("T")

POSE_FORM = "a pose is x,y,dir_deg in metres and degrees, e.g. 1.5,3,0"
POINT_FORM = "a point is x,y in metres, e.g. 10.5,3"
POINTS_FORM = "waypoints are x,y;x,y;... in metres, e.g. 16,5.55;21.5,6.5"
BOXES_FORM = "boxes are x0,y0,x1,y1;... in metres (opposite corners), e.g. 4,2,5,4;8,1,9,2"
BOX_HEIGHT_M = 1.0  # a box read from a command line is a wall this high


def _read(text: str, count: int) -> tuple[tuple[float, ...], str]:
    """``count`` finite numbers separated by commas, and "" ; or what is wrong with them."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != count:
        return (), f"{len(parts)} number{'s' if len(parts) != 1 else ''}"
    out = []
    for p in parts:
        try:
            v = float(p)
        except ValueError:
            return (), f"{p!r} is not a number"
        if not math.isfinite(v):
            return (), f"{p!r} is not a finite number"
        out.append(v)
    return tuple(out), ""


def _numbers(text: str, count: int, form: str) -> tuple[float, ...]:
    """``count`` finite numbers separated by commas, or a ValueError saying the form."""
    values, why = _read(text, count)
    if why:
        raise ValueError(f"{form}; got {text!r} ({why})")
    return values


def parse_pose(text: str) -> tuple[float, float, float]:
    """Reads ``x,y,dir_deg``.

    Args:
        text: The pose as written.

    Returns:
        (x m, y m, heading deg).

    Raises:
        ValueError: Saying the form and what is wrong with ``text``.
    """
    x, y, d = _numbers(text, 3, POSE_FORM)
    return x, y, d


def parse_point(text: str) -> tuple[float, float]:
    """Reads ``x,y``.

    Args:
        text: The point as written.

    Returns:
        (x m, y m).

    Raises:
        ValueError: Saying the form and what is wrong with ``text``.
    """
    x, y = _numbers(text, 2, POINT_FORM)
    return x, y


def parse_points(text: str) -> list[tuple[float, float]]:
    """Reads ``x,y;x,y;...`` (at least one point; empty parts between ``;`` are skipped).

    Args:
        text: The points as written.

    Returns:
        The points in order, metres.

    Raises:
        ValueError: Saying the form, and which point is wrong.
    """
    parts = [p for p in text.split(";") if p.strip()]
    if not parts:
        raise ValueError(f"{POINTS_FORM}; got {text!r} (no point)")
    out = []
    for i, part in enumerate(parts):
        values, why = _read(part, 2)
        if why:
            raise ValueError(f"{POINTS_FORM}; got {text!r} (point {i + 1}, {part.strip()!r}: {why})")
        out.append((values[0], values[1]))
    return out


def parse_boxes(text: str) -> tuple[Wall, ...]:
    """Reads ``x0,y0,x1,y1;...``, axis-aligned boxes, as walls :data:`BOX_HEIGHT_M` high (none
    for an empty text; empty parts between ``;`` are skipped).

    Args:
        text: The boxes as written.

    Returns:
        One wall a box, counter-clockwise from ``(x0, y0)`` when ``x0 < x1`` and ``y0 < y1``.

    Raises:
        ValueError: Saying the form, and which box is wrong.
    """
    from iw_zenoh.core.lab import Wall  # here: light agents import this module, and lab loads shapely

    out = []
    for i, part in enumerate(p for p in text.split(";") if p.strip()):
        values, why = _read(part, 4)
        if why:
            raise ValueError(f"{BOXES_FORM}; got {text!r} (box {i + 1}, {part.strip()!r}: {why})")
        x0, y0, x1, y1 = values
        out.append(Wall(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), BOX_HEIGHT_M))
    return tuple(out)


def _as_arg(parse: Callable[[str], T]) -> Callable[[str], T]:
    def convert(text: str) -> T:
        try:
            return parse(text)
        except ValueError as e:  # argparse prints an ArgumentTypeError's own words
            raise argparse.ArgumentTypeError(str(e)) from None

    convert.__name__ = parse.__name__.removeprefix("parse_")
    return convert


pose_arg = _as_arg(parse_pose)
pose_arg.__doc__ = "argparse ``type=`` for a pose ``x,y,dir_deg`` (see :func:`parse_pose`)."
point_arg = _as_arg(parse_point)
point_arg.__doc__ = "argparse ``type=`` for a point ``x,y`` (see :func:`parse_point`)."
points_arg = _as_arg(parse_points)
points_arg.__doc__ = "argparse ``type=`` for waypoints ``x,y;x,y;...`` (see :func:`parse_points`)."
