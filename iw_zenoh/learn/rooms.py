"""The rooms ChairNav draws its episodes from, and free places in them for starts and goals."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from iw_zenoh.core.lab import Lab, Wall

__all__ = ["free_point", "random_room", "start_and_goal"]

SIZES = ((8.0, 6.0), (10.0, 8.0), (12.0, 8.0), (12.0, 10.0))  # room sizes, m
MAX_BOXES = 4


def random_room(g: np.random.Generator) -> Lab:
    """A room of one of :data:`SIZES` with up to :data:`MAX_BOXES` box obstacles (0.4 to 1.5 m)."""
    w, h = SIZES[int(g.integers(len(SIZES)))]
    walls = []
    for _ in range(int(g.integers(0, MAX_BOXES + 1))):
        bw, bh = g.uniform(0.4, 1.5, 2)
        x, y = g.uniform(1.0, w - 1.0 - bw), g.uniform(1.0, h - 1.0 - bh)
        walls.append(Wall(((x, y), (x + bw, y), (x + bw, y + bh), (x, y + bh)), 2.0))
    return Lab(f"room-{w:g}x{h:g}", w, h, tuple(walls))


def free_point(
    g: np.random.Generator, lab: Lab, margin: float, away: Sequence[tuple[float, float]] = ()
) -> tuple[float, float]:
    """A point at least ``margin`` from the lab's edges and every wall's bounding box, and at least
    two margins from each point of ``away`` (other chairs' starts, a start for its goal).

    Raises:
        ValueError: No such point found in a thousand tries (the lab is too full).
    """
    boxes = [
        (
            min(x for x, _ in w.corners),
            min(y for _, y in w.corners),
            max(x for x, _ in w.corners),
            max(y for _, y in w.corners),
        )
        for w in lab.walls
    ]
    for _ in range(1000):
        x, y = g.uniform(margin, lab.width_m - margin), g.uniform(margin, lab.height_m - margin)
        if any(x0 - margin < x < x1 + margin and y0 - margin < y < y1 + margin for x0, y0, x1, y1 in boxes):
            continue
        if any(math.hypot(x - ax, y - ay) < 2 * margin for ax, ay in away):
            continue
        return float(x), float(y)
    raise ValueError(f"no free place {margin} m from the walls of {lab.name!r}")


def start_and_goal(
    g: np.random.Generator, lab: Lab, margin: float, away: Sequence[tuple[float, float]] = (), *, tries: int = 20
) -> tuple[tuple[float, float], tuple[float, float]]:
    """A start (:func:`free_point`, two margins from each point of ``away``) and a goal two
    margins from it; another start when none is found for one (a start in a small pocket of a
    crowded room may have no place that far within its reach... or anywhere).

    Raises:
        ValueError: No pair found from ``tries`` starts, or no start at all.
    """
    for _ in range(tries):
        start = free_point(g, lab, margin, away)
        try:
            return start, free_point(g, lab, margin, away=[start])
        except ValueError:
            continue
    raise ValueError(f"no start and goal {2 * margin:g} m apart and {margin:g} m from the walls of {lab.name!r}")
