"""Planning for a rectangular chair: A* over (x, y, heading).

A chair 1.04 m long that turns about a point near its front axle sweeps far more room than a
disc of its half width: planning it as such a disc (:mod:`iw_zenoh.core.planning`) lets its
corners graze what it passes. Here A* searches the chair's three-dimensional configuration space
(:mod:`iw_zenoh.core.posespace`: for each of 48 headings the walls grown by the chair's own
outline at that heading; its ``Footprint``, ``PoseSpace`` and ``occupancy`` are re-exported
here). A* moves by 0.2 m arcs of five curvatures (straight included), by turns on the spot of
15 degrees, allowed only when every intermediate heading is free too (the turn's swept area), or
straight back (dearly: a way out of a tight spot, not a way to travel). Every move is checked
against the outline every 5 cm, and the follower drives what the lattice checked.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from iw_zenoh.core.posespace import NH, Footprint, PoseSpace, occupancy

__all__ = ["PRIMITIVES", "Footprint", "PosePath", "PoseSpace", "occupancy", "pose_plan"]

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]
Point = tuple[float, float]

STEP_M = 0.2  # arc length of one motion primitive
CURVATURES = (0.0, 1.2, -1.2, 3.0, -3.0)  # 1/m; 3/m is a 0.33 m radius, inside the chair's reach
TURN_BINS = 2  # a turn on the spot turns this many heading bins (15 degrees)
TURN_COST_M = 0.25  # and costs as much as this much driving
CURVE_COST = 0.1  # extra cost per metre per unit of |curvature| (prefer straight)
REVERSE_COST = 3.0  # backing up (straight) costs this many times as much as driving ahead: a
# way out when the chair is wedged, not a way to travel (it has one sensor behind)
SAMPLE_M = 0.05  # check the footprint this often along a primitive


@dataclass(frozen=True)
class PosePath:
    """A planned path.

    Attributes:
        poses: (K, 3) x, y, heading (rad) every few centimetres from start to end; a turn on the
            spot is a run of poses at one place with changing headings.
        expanded: States A* expanded (its cost).
    """

    poses: FloatArray
    expanded: int


def _primitives() -> list[tuple[FloatArray, float]]:
    """Motion primitives in the chair's frame: (samples (S, 3) of dx, dy, dheading; cost)."""
    out: list[tuple[FloatArray, float]] = []
    n = int(round(STEP_M / SAMPLE_M))
    for k in CURVATURES:
        s = np.linspace(SAMPLE_M, STEP_M, n)
        if k == 0.0:
            pts = np.column_stack([s, np.zeros(n), np.zeros(n)])
        else:
            th = k * s
            pts = np.column_stack([np.sin(th) / k, (1.0 - np.cos(th)) / k, th])
        out.append((pts, STEP_M * (1.0 + CURVE_COST * abs(k))))
    s = np.linspace(SAMPLE_M, STEP_M, n)
    out.append((np.column_stack([-s, np.zeros(n), np.zeros(n)]), STEP_M * REVERSE_COST))
    for d in (1, -1):
        step = 2 * math.pi / NH
        th = d * step * TURN_BINS * np.linspace(1.0 / n, 1.0, n)  # n samples, like the arcs
        out.append((np.column_stack([np.zeros(n), np.zeros(n), th]), TURN_COST_M))
    return out


PRIMITIVES = _primitives()
COARSE = 4  # the heuristic's grid: cells this many planning cells across


def _wavefront(space: PoseSpace, goal: Point, reach_m: float) -> tuple[npt.NDArray[np.float64], float]:
    """Steps (8-connected, so never more than the straight-line distance) from every coarse cell
    to the goal through cells where the chair fits at some heading: a lower bound of the path
    length that, unlike the straight line, knows about walls (so A* looks for the doorway
    instead of filling the room first). Returns (steps, coarse cell size)."""
    k = COARSE
    fits = ~np.all(space.blocked, axis=0)
    rows, cols = -(-space.rows // k), -(-space.cols // k)
    pad = np.zeros((rows * k, cols * k), dtype=bool)
    pad[: space.rows, : space.cols] = fits
    free = pad.reshape(rows, k, cols, k).any(axis=(1, 3))
    size = space.cell_m * k
    gr = int((goal[1] / space.cell_m - space.r0) / k)
    gc = int((goal[0] / space.cell_m - space.c0) / k)
    dist = np.full((rows, cols), np.inf)
    rr, cc = np.mgrid[0:rows, 0:cols]
    seed = np.hypot(rr - gr, cc - gc) <= reach_m / size + 1
    front = seed & free
    if not front.any():
        front = seed
    reached = front.copy()
    steps = 0
    while front.any():
        dist[front] = steps
        grown = front.copy()
        grown[1:, :] |= front[:-1, :]
        grown[:-1, :] |= front[1:, :]
        g2 = grown.copy()
        g2[:, 1:] |= grown[:, :-1]
        g2[:, :-1] |= grown[:, 1:]
        front = g2 & free & ~reached
        reached |= front
        steps += 1
    return dist, size


_BIN_RAD = 2 * math.pi / NH  # the heading bins' width


class _Moves(NamedTuple):
    """Every primitive's samples at once, in the chair's frame: (P, S) offsets and P costs."""

    dx: FloatArray
    dy: FloatArray
    dheading: FloatArray
    costs: list[float]


def _moves() -> _Moves:
    """:data:`PRIMITIVES` stacked for a vectorized expansion."""
    return _Moves(
        np.stack([q[0][:, 0] for q in PRIMITIVES]),
        np.stack([q[0][:, 1] for q in PRIMITIVES]),
        np.stack([q[0][:, 2] for q in PRIMITIVES]),
        [q[1] for q in PRIMITIVES],
    )


def _state(cell_m: float, x: float, y: float, heading_rad: float) -> tuple[int, int, int]:
    """The lattice state of a pose: its cell and its nearest heading bin."""
    return int(x / cell_m), int(y / cell_m), round(heading_rad / _BIN_RAD) % NH


def _heuristic(space: PoseSpace, goal: Point, reach_m: float) -> Callable[[float, float], float]:
    """A lower bound of the way left from (x, y): the straight line to within ``reach_m`` of the
    goal, or the wall-aware :func:`_wavefront` where it knows better."""
    cell, r0, c0 = space.cell_m, space.r0, space.c0
    gx, gy = goal
    wave, wsize = _wavefront(space, goal, reach_m)
    wrows, wcols = wave.shape

    def h_of(x: float, y: float) -> float:
        straight = max(0.0, math.hypot(gx - x, gy - y) - reach_m)
        r = int((y / cell - r0) / COARSE)
        c = int((x / cell - c0) / COARSE)
        if 0 <= r < wrows and 0 <= c < wcols and math.isfinite(wave[r, c]):
            return max(straight, float(wave[r, c] - 2.0) * wsize)
        return straight

    return h_of


def _expand(
    space: PoseSpace, moves: _Moves, x: float, y: float, th: float
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    """Every primitive from a pose in the world: the samples' x, y and heading, (P, S) each, and
    which primitives keep the chair free at every sample, (P,)."""
    cell = space.cell_m
    c, s = math.cos(th), math.sin(th)
    wx = x + c * moves.dx - s * moves.dy
    wy = y + s * moves.dx + c * moves.dy
    wt = th + moves.dheading
    rr = (wy / cell).astype(np.int64) - space.r0
    cc = (wx / cell).astype(np.int64) - space.c0
    inside = (rr >= 0) & (rr < space.rows) & (cc >= 0) & (cc < space.cols)
    jj = np.round(wt / _BIN_RAD).astype(np.int64) % NH
    hit = ~inside
    hit[inside] = space.blocked[jj[inside], rr[inside], cc[inside]]
    return wx, wy, wt, ~hit.any(axis=1)


def _path_to(
    end: int, start: tuple[float, float, float], parent: list[int], via: list[FloatArray | None]
) -> FloatArray:
    """The poses from the start to node ``end``, (K, 3), headings wrapped to [-pi, pi)."""
    chain: list[FloatArray] = []
    node = end
    while node > 0:
        v = via[node]
        assert v is not None
        chain.append(v)
        node = parent[node]
    chain.append(np.array([start], dtype=np.float64))
    path = np.concatenate(chain[::-1])
    path[:, 2] = np.remainder(path[:, 2] + math.pi, 2 * math.pi) - math.pi
    return path


def _a_star(
    space: PoseSpace, start: tuple[float, float, float], goal: Point, *, reach_m: float, max_expand: int, weight: float
) -> tuple[int, int, list[int], list[FloatArray | None]]:
    """The search of :func:`pose_plan` from a free start.

    Returns:
        ``(end, expanded, parent, via)``: the node that reached the goal (-1 for none), the
        states expanded, and each node's parent and primitive samples (for :func:`_path_to`).
    """
    cell = space.cell_m
    gx, gy = goal
    h_of = _heuristic(space, goal, reach_m)
    moves = _moves()
    # pose of each node; parent and the primitive's samples to rebuild the path
    poses: list[tuple[float, float, float]] = [start]
    parent: list[int] = [-1]
    via: list[FloatArray | None] = [None]
    best: dict[tuple[int, int, int], float] = {_state(cell, *start): 0.0}
    heap: list[tuple[float, float, int]] = [
        (weight * max(0.0, math.hypot(gx - start[0], gy - start[1]) - reach_m), 0.0, 0)
    ]
    expanded = 0
    end = -1
    while heap and expanded < max_expand:
        _, g_now, node = heapq.heappop(heap)
        x, y, th = poses[node]
        if g_now > best.get(_state(cell, x, y, th), math.inf):
            continue
        expanded += 1
        if math.hypot(gx - x, gy - y) <= reach_m:
            end = node
            break
        wx, wy, wt, ok = _expand(space, moves, x, y, th)
        for i in np.flatnonzero(ok).tolist():
            nx, ny, nt = float(wx[i, -1]), float(wy[i, -1]), math.remainder(float(wt[i, -1]), 2 * math.pi)
            k = _state(cell, nx, ny, nt)
            new = g_now + moves.costs[i]
            if new < best.get(k, math.inf):
                best[k] = new
                poses.append((nx, ny, nt))
                parent.append(node)
                via.append(np.column_stack([wx[i], wy[i], wt[i]]))
                h = h_of(nx, ny)
                heapq.heappush(heap, (new + weight * h, new, len(poses) - 1))
    return end, expanded, parent, via


def pose_plan(
    space: PoseSpace,
    start: tuple[float, float, float],
    goal: Point,
    *,
    reach_m: float = 0.1,
    max_expand: int = 60_000,
    weight: float = 2.0,
) -> PosePath | None:
    """Hybrid A* from a pose to within ``reach_m`` of a point, for the rectangular chair: arcs
    of a few curvatures and turns on the spot, each checked against the chair's outline every
    few centimetres.

    Args:
        space: The configuration space.
        start: (x, y, heading_rad).
        goal: Where to end (any heading).
        reach_m: Ending this near the goal will do (the goal itself may not fit the chair).
        max_expand: Give up after this many states.
        weight: Heuristic weight (1 is optimal; above 1 is faster and near-optimal).

    Returns:
        The path, or None when there is none (or the chair does not fit at the start).
    """
    if not space.free(*start):
        return None
    end, expanded, parent, via = _a_star(space, start, goal, reach_m=reach_m, max_expand=max_expand, weight=weight)
    if end < 0:
        return None
    return PosePath(_path_to(end, start, parent, via), expanded)
