"""The collision check's narrow phase, compiled: which robots' outlines touch a wall or each
other, found in the cell grid the proximity cones use too (:mod:`iw_zenoh.core.cellgrid`)
instead of R-trees and GEOS polygons.

Why compiled (numba): with shapely, each tick built R-trees, query boxes and a GEOS polygon per
candidate, about a hundred library calls whose fixed costs made 100 chairs take 2.5 ms and
1,000 chairs 6-10 ms, on the critical path of every tick (the world waits for the verdict).

What "touch" means here is what :func:`shapely.intersects` means for closed polygons, with one
difference on purpose: two outlines closer than :data:`TOUCH_M` (a nanometre) count as touching,
so a rounding error can only ever add a collision, never hide one. Robot outlines are convex
(rectangles, or polygons of circles); walls are any simple polygons. Two polygons touch when an
edge of one comes within :data:`TOUCH_M` of an edge of the other, or when neither edge does and
one lies inside the other (then any vertex of it is inside: tested with one vertex each way).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

from iw_zenoh.core import placing
from iw_zenoh.core.cellgrid import CellGrid, bin_boxes, gather, in_convex, in_wall, scene_walls
from iw_zenoh.core.lab import Lab, Scene, Wall

__all__ = ["TOUCH_M", "touching", "warm_up"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

TOUCH_M = 1e-9  # outlines closer than this touch (rounding adds collisions, never hides them)


def touching(
    scene: Scene,
    c_now: FloatArray,
    c_mid: FloatArray,
    c_next: FloatArray,
    wall_free: BoolArray,
) -> tuple[IntArray, IntArray]:
    """Robot-wall and robot-robot contacts of one tick.

    A robot hits a wall when its next outline touches it, or when the convex hull of its
    current, half-way and next outlines does and its current outline does not; it hits the
    border (wall index ``len(lab.walls)``) when its next outline leaves the lab (the lab is
    convex: an outline that stays inside never crossed it). Robots i < j hit each other when
    their next outlines touch, or their half-way ones do and their current ones do not. Only
    candidates whose swept boxes overlap are tested.

    Args:
        scene: The lab.
        c_now: (N, K, 2) current outlines in the world, counter-clockwise.
        c_mid: (N, K, 2) outlines half-way through the tick.
        c_next: (N, K, 2) next outlines.
        wall_free: (N,) robots that pass through walls and the border (doors).

    Returns:
        ``(wall_pairs, robot_pairs)``: (P, 2) ``[robot, wall]`` sorted, and (Q, 2) ``[i, j]``
        with i < j, sorted.
    """
    w = scene_walls(scene)
    g = w.grid
    return _touching(
        np.ascontiguousarray(c_now, dtype=np.float64),
        np.ascontiguousarray(c_mid, dtype=np.float64),
        np.ascontiguousarray(c_next, dtype=np.float64),
        np.ascontiguousarray(wall_free, dtype=np.bool_),
        float(scene.lab.width_m),
        float(scene.lab.height_m),
        w.segs,
        w.wall_first,
        w.wall_count,
        w.wall_box,
        w.wall_start,
        w.wall_items,
        g,
        False,
    )


@njit(cache=True, nogil=True)
def _point_seg2(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:  # pragma: no cover
    """Squared distance from p to segment a-b."""
    dx = bx - ax
    dy = by - ay
    dd = dx * dx + dy * dy
    t = 0.0
    if dd > 0.0:
        t = min(max(((px - ax) * dx + (py - ay) * dy) / dd, 0.0), 1.0)
    qx = ax + t * dx - px
    qy = ay + t * dy - py
    return qx * qx + qy * qy


@njit(cache=True, nogil=True)
def _segs_touch(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float, dx: float, dy: float
) -> bool:  # pragma: no cover
    """Whether segments a-b and c-d cross or come within TOUCH_M of each other."""
    d1 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
    d2 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
    d3 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    d4 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
    if ((d1 > 0.0 and d2 < 0.0) or (d1 < 0.0 and d2 > 0.0)) and ((d3 > 0.0 and d4 < 0.0) or (d3 < 0.0 and d4 > 0.0)):
        return True  # a proper crossing
    t2 = TOUCH_M * TOUCH_M
    return (
        _point_seg2(ax, ay, cx, cy, dx, dy) <= t2
        or _point_seg2(bx, by, cx, cy, dx, dy) <= t2
        or _point_seg2(cx, cy, ax, ay, bx, by) <= t2
        or _point_seg2(dx, dy, ax, ay, bx, by) <= t2
    )


@njit(cache=True, nogil=True)
def _convex_touch(p: FloatArray, kp: int, q: FloatArray, kq: int) -> bool:  # pragma: no cover
    for e in range(kp):
        f = (e + 1) % kp
        for g in range(kq):
            h = (g + 1) % kq
            if _segs_touch(p[e, 0], p[e, 1], p[f, 0], p[f, 1], q[g, 0], q[g, 1], q[h, 0], q[h, 1]):
                return True
    return in_convex(p[0, 0], p[0, 1], q, kq) or in_convex(q[0, 0], q[0, 1], p, kp)


@njit(cache=True, nogil=True)
def _wall_touch(p: FloatArray, kp: int, segs: FloatArray, first: int, count: int) -> bool:  # pragma: no cover
    """Whether convex polygon ``p[:kp]`` touches the wall whose edges are segs[first:first+count]."""
    for s in range(first, first + count):
        for e in range(kp):
            f = (e + 1) % kp
            if _segs_touch(p[e, 0], p[e, 1], p[f, 0], p[f, 1], segs[s, 0], segs[s, 1], segs[s, 2], segs[s, 3]):
                return True
    # no edges touch: the wall is inside the body, or the body inside the wall, or neither
    return in_convex(segs[first, 0], segs[first, 1], p, kp) or in_wall(p[0, 0], p[0, 1], segs, first, count)


@njit(cache=True, nogil=True)
def _cross(ox: float, oy: float, ax: float, ay: float, bx: float, by: float) -> float:  # pragma: no cover
    return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox)


@njit(cache=True, nogil=True)
def _hull(pts: FloatArray, out: FloatArray) -> int:  # pragma: no cover
    """Convex hull of ``pts`` into ``out`` (room for 2n points), counter-clockwise (Andrew's
    monotone chain); returns its vertex count."""
    n = pts.shape[0]
    order = np.arange(n)
    for a in range(1, n):  # by x, then y (a dozen points: insertion sort)
        b = a
        while b > 0:
            i, j = order[b - 1], order[b]
            if pts[i, 0] > pts[j, 0] or (pts[i, 0] == pts[j, 0] and pts[i, 1] > pts[j, 1]):
                order[b - 1] = j
                order[b] = i
                b -= 1
            else:
                break
    m = 0
    for t in range(n):
        px, py = pts[order[t], 0], pts[order[t], 1]
        while m >= 2 and _cross(out[m - 2, 0], out[m - 2, 1], out[m - 1, 0], out[m - 1, 1], px, py) <= 0.0:
            m -= 1
        out[m, 0] = px
        out[m, 1] = py
        m += 1
    lo = m + 1
    for t in range(n - 2, -1, -1):
        px, py = pts[order[t], 0], pts[order[t], 1]
        while m >= lo and _cross(out[m - 2, 0], out[m - 2, 1], out[m - 1, 0], out[m - 1, 1], px, py) <= 0.0:
            m -= 1
        out[m, 0] = px
        out[m, 1] = py
        m += 1
    return max(m - 1, 1)  # the last point is the first again


@njit(cache=True, nogil=True)
def _push(pairs: IntArray, n: int, a: int, b: int) -> IntArray:  # pragma: no cover
    if n == pairs.shape[0]:
        bigger = np.empty((2 * n + 16, 2), dtype=np.int64)
        bigger[:n] = pairs[:n]
        pairs = bigger
    pairs[n, 0] = a
    pairs[n, 1] = b
    return pairs


@njit(cache=True, nogil=True)
def _touching(
    c_now: FloatArray,
    c_mid: FloatArray,
    c_next: FloatArray,
    wall_free: BoolArray,
    width: float,
    height: float,
    segs: FloatArray,
    wall_first: IntArray,
    wall_count: IntArray,
    wall_box: FloatArray,
    wall_start: IntArray,
    wall_items: IntArray,
    g: CellGrid,
    pass_free: bool,
) -> tuple[IntArray, IntArray]:  # pragma: no cover
    n = c_now.shape[0]
    k = c_now.shape[1]
    nw = wall_box.shape[0]
    sweep = np.empty((n, 3 * k, 2), dtype=np.float64)
    box = np.empty((n, 4), dtype=np.float64)
    outside = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        sweep[i, :k] = c_now[i]
        sweep[i, k : 2 * k] = c_mid[i]
        sweep[i, 2 * k :] = c_next[i]
        box[i, 0] = sweep[i, :, 0].min() - TOUCH_M  # widened: near enough to touch is a candidate
        box[i, 1] = sweep[i, :, 1].min() - TOUCH_M
        box[i, 2] = sweep[i, :, 0].max() + TOUCH_M
        box[i, 3] = sweep[i, :, 1].max() + TOUCH_M
        outside[i] = not wall_free[i] and (
            c_next[i, :, 0].min() < 0.0
            or c_next[i, :, 1].min() < 0.0
            or c_next[i, :, 0].max() > width
            or c_next[i, :, 1].max() > height
        )
    b_start, b_items = bin_boxes(box, g.x0, g.y0, g.cell, g.nx, g.ny)
    walls = np.empty((16, 2), dtype=np.int64)
    nwp = 0
    robots = np.empty((16, 2), dtype=np.int64)
    nrp = 0
    seen = np.full(max(nw, 1), -1, dtype=np.int64)
    near = np.empty(max(nw, 1), dtype=np.int64)
    seen_robot = np.full(n, -1, dtype=np.int64)
    near_robot = np.empty(n, dtype=np.int64)
    hull = np.empty((2 * sweep.shape[1] + 1, 2), dtype=np.float64)
    for i in range(n):
        x0, y0, x1, y1 = box[i, 0], box[i, 1], box[i, 2], box[i, 3]
        if not wall_free[i] and nw:
            hk = -1  # the sweep's hull, built when a wall needs it
            first_wall = nwp
            for t in range(gather(g, wall_start, wall_items, wall_box, seen, i, x0, y0, x1, y1, near)):
                w = near[t]
                f, m = wall_first[w], wall_count[w]
                hit = _wall_touch(c_next[i], k, segs, f, m)
                if not hit:
                    if hk < 0:
                        hk = _hull(sweep[i], hull)
                    hit = _wall_touch(hull, hk, segs, f, m) and not _wall_touch(c_now[i], k, segs, f, m)
                if hit:
                    walls = _push(walls, nwp, i, w)
                    nwp += 1
            # this robot's walls in index order
            for a in range(first_wall + 1, nwp):
                b = a
                while b > first_wall and walls[b - 1, 1] > walls[b, 1]:
                    t = walls[b - 1, 1]
                    walls[b - 1, 1] = walls[b, 1]
                    walls[b, 1] = t
                    b -= 1
        if outside[i]:
            walls = _push(walls, nwp, i, nw)
            nwp += 1
        # robots: each pair once, from its lower index
        for t in range(gather(g, b_start, b_items, box, seen_robot, i, x0, y0, x1, y1, near_robot)):
            j = near_robot[t]
            if j <= i or (pass_free and wall_free[i] and wall_free[j]):
                continue
            hit = _convex_touch(c_next[i], k, c_next[j], k)
            if not hit:
                hit = _convex_touch(c_mid[i], k, c_mid[j], k) and not _convex_touch(c_now[i], k, c_now[j], k)
            if hit:
                robots = _push(robots, nrp, i, j)
                nrp += 1
    robots = robots[:nrp]
    if nrp > 1:
        robots = robots[np.argsort(robots[:, 0] * n + robots[:, 1], kind="mergesort")]
    return walls[:nwp].copy(), robots.copy()


def warm_up() -> None:
    """Compiles the kernel now (or loads it from the cache), so the first tick is not slow."""
    scene = Scene(Lab("warm-up", 4.0, 4.0, (Wall(((1.0, 1.0), (2.0, 1.0), (2.0, 2.0)), 1.0),)))
    sq = np.asarray(
        [[[0.1, 0.1], [0.3, 0.1], [0.3, 0.3], [0.1, 0.3]], [[0.2, 0.2], [0.4, 0.2], [0.4, 0.4], [0.2, 0.4]]]
    )
    touching(scene, sq, sq + 0.5, sq + 1.0, np.zeros(2, dtype=np.bool_))
    placing.warm_up()  # the outlines the check places
