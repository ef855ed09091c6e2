"""The proximity cones' narrow phase, compiled: walls and bodies binned into the uniform grid of
square cells of :mod:`iw_zenoh.core.cellgrid`, and one loop per cone over the cells its
sector's box covers.

Why compiled (numba): the same computation in vectorized numpy spent most of its time building
index arrays of (cone, candidate) pairs and R-tree query boxes, not in the arithmetic; with
1,000 chairs of eight cones it cost 30-45 ms a tick, the largest share of a lock-step tick. A
loop per cone needs none of those arrays. The arithmetic is the vectorized version's, operation
for operation, so every distance is the same bit for bit
(:func:`iw_zenoh.core.sensors.proximity_distances` documents what a cone sees).

Compiled once per machine and cached next to this file (numba's ``cache=True``), or, where the
package is installed read-only, in numba's per-user cache (``~/.cache/numba``) or the folder
``NUMBA_CACHE_DIR`` names; the first call in a fresh install takes a few seconds, later processes
load the cache (``tests/core/test_kernel_cache.py``, docs/runtime.md "Memory").
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from iw_zenoh.core.cellgrid import SceneIndex, gather, in_convex, in_walls, scene_index
from iw_zenoh.core.lab import Lab, Scene, Wall

__all__ = ["cone_distances", "warm_up"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def cone_distances(
    scene: Scene,
    ox: FloatArray,
    oy: FloatArray,
    normals: FloatArray,
    range_m: FloatArray,
    box_lo: FloatArray,
    box_hi: FloatArray,
    owner: IntArray,
    body_xy: FloatArray,
    *,
    index: SceneIndex | None = None,
) -> FloatArray:
    """Distance each cone sees (``inf`` beyond its range).

    Args:
        scene: The lab.
        ox: (M,) cone apex x (the sensor's mounting point).
        oy: (M,) apex y.
        normals: (M, 4) inward normals ``(lx, ly, rx, ry)`` of each cone's left and right edges.
        range_m: (M,) ranges.
        box_lo: (M, 2) lower corner of each cone's exact bounding box.
        box_hi: (M, 2) upper corner.
        owner: (M,) the body each cone is mounted on (it does not see itself).
        body_xy: (N, K, 2) every body's outline in the world, counter-clockwise.
        index: :func:`~iw_zenoh.core.cellgrid.scene_index` of ``scene`` and ``body_xy``, when the
            caller has it already (the sensors build it once a tick for the cones and the laser).
    """
    box = np.ascontiguousarray(np.concatenate([box_lo, box_hi], axis=1), dtype=np.float64)
    return np.asarray(
        _scan(
            np.ascontiguousarray(ox, dtype=np.float64),
            np.ascontiguousarray(oy, dtype=np.float64),
            np.ascontiguousarray(normals, dtype=np.float64),
            np.ascontiguousarray(range_m, dtype=np.float64),
            box,
            np.ascontiguousarray(owner, dtype=np.int64),
            scene_index(scene, body_xy) if index is None else index,
        ),
        dtype=np.float64,
    )


@njit(cache=True, nogil=True)
def _wedge(
    px: float, py: float, lx: float, ly: float, rx: float, ry: float, ax: float, ay: float, bx: float, by: float
) -> float:  # pragma: no cover
    """Distance from apex p to the part of segment a-b inside the wedge whose inward edge
    normals are (lx, ly) and (rx, ry) (inf if none): the segment is clipped against both
    half-planes through p, then the nearest point of what is left is taken."""
    dx = bx - px - (ax - px)
    dy = by - py - (ay - py)
    ax = ax - px
    ay = ay - py
    lo = 0.0
    hi = 1.0
    for k in range(2):
        nx = lx if k == 0 else rx
        ny = ly if k == 0 else ry
        f0 = nx * ax + ny * ay
        df = nx * dx + ny * dy
        neg0 = f0 < 0.0
        neg1 = (f0 + df) < 0.0
        if neg0 and neg1:
            return math.inf
        if neg0 and not neg1:
            lo = max(lo, -f0 / df)
        elif neg1 and not neg0:
            hi = min(hi, -f0 / df)
    if lo > hi:
        return math.inf
    dd = dx * dx + dy * dy
    t = lo
    if dd > 0.0:
        t = min(max(-(ax * dx + ay * dy) / dd, lo), hi)
    qx = ax + t * dx
    qy = ay + t * dy
    return math.sqrt(qx * qx + qy * qy)


@njit(cache=True, nogil=True)
def _scan(
    ox: FloatArray,
    oy: FloatArray,
    nrm: FloatArray,
    rng: FloatArray,
    box: FloatArray,
    owner: IntArray,
    ix: SceneIndex,
) -> FloatArray:  # pragma: no cover
    best = np.empty(ox.shape[0])
    _scan_part(0, ox.shape[0], ox, oy, nrm, rng, box, owner, ix, best)
    return best


@njit(cache=True, nogil=True)
def _scan_part(
    i0: int,
    i1: int,
    ox: FloatArray,
    oy: FloatArray,
    nrm: FloatArray,
    rng: FloatArray,
    box: FloatArray,
    owner: IntArray,
    ix: SceneIndex,
    best: FloatArray,
) -> None:  # pragma: no cover
    """Sensors ``i0`` to ``i1 - 1``: their distances written to ``best``."""
    w, g = ix.walls, ix.walls.grid
    segs, seg_box, bbox = w.segs, w.seg_box, ix.bbox
    seen_seg = np.full(segs.shape[0], -1, dtype=np.int64)
    seen_body = np.full(bbox.shape[0], -1, dtype=np.int64)
    near_seg = np.empty(segs.shape[0], dtype=np.int64)
    near_body = np.empty(bbox.shape[0], dtype=np.int64)
    i = i0
    while i < i1:
        # a robot's cones (neighbours, one owner) look its walls and bodies up once, in the box
        # around all their boxes; each cone then tests the ones whose box meets its own: the
        # same candidates as a look-up of its own, so the same minimum
        j = i + 1
        while j < i1 and owner[j] == owner[i]:
            j += 1
        ux0, uy0, ux1, uy1 = box[i, 0], box[i, 1], box[i, 2], box[i, 3]
        for c in range(i + 1, j):
            ux0, uy0 = min(ux0, box[c, 0]), min(uy0, box[c, 1])
            ux1, uy1 = max(ux1, box[c, 2]), max(uy1, box[c, 3])
        n_seg = gather(g, w.seg_start, w.seg_items, seg_box, seen_seg, i, ux0, uy0, ux1, uy1, near_seg)
        n_body = gather(g, ix.b_start, ix.b_items, bbox, seen_body, i, ux0, uy0, ux1, uy1, near_body)
        for c in range(i, j):
            best[c] = _cone(c, ox, oy, nrm, rng, box, owner, ix, near_seg, n_seg, near_body, n_body)
        i = j


# inlined (numba IR) into the loop over a robot's cones: a call passing the index's tuple pays
# reference counts on each of its arrays
@njit(cache=True, nogil=True, inline="always")
def _cone(
    i: int,
    ox: FloatArray,
    oy: FloatArray,
    nrm: FloatArray,
    rng: FloatArray,
    box: FloatArray,
    owner: IntArray,
    ix: SceneIndex,
    near_seg: IntArray,
    n_seg: int,
    near_body: IntArray,
    n_body: int,
) -> float:  # pragma: no cover
    """Sensor ``i``'s distance, ``inf`` beyond its range, from the candidate walls' edges and
    bodies (``near_seg[:n_seg]``, ``near_body[:n_body]``: every one whose box meets its box)."""
    w = ix.walls
    segs, seg_box, bbox, body_xy = w.segs, w.seg_box, ix.bbox, ix.body_xy
    k = body_xy.shape[1]
    px, py = ox[i], oy[i]
    lx, ly, rx, ry = nrm[i, 0], nrm[i, 1], nrm[i, 2], nrm[i, 3]
    x0, y0, x1, y1 = box[i, 0], box[i, 1], box[i, 2], box[i, 3]
    d = math.inf
    for t in range(n_seg):
        s = near_seg[t]
        if seg_box[s, 0] > x1 or seg_box[s, 2] < x0 or seg_box[s, 1] > y1 or seg_box[s, 3] < y0:
            continue
        d = min(d, _wedge(px, py, lx, ly, rx, ry, segs[s, 0], segs[s, 1], segs[s, 2], segs[s, 3]))
    for t in range(n_body):
        b = near_body[t]
        if b == owner[i] or bbox[b, 0] > x1 or bbox[b, 2] < x0 or bbox[b, 1] > y1 or bbox[b, 3] < y0:
            continue
        inside_box = bbox[b, 0] <= px <= bbox[b, 2] and bbox[b, 1] <= py <= bbox[b, 3]
        if inside_box and in_convex(px, py, body_xy[b], k):
            d = 0.0  # a mounting point inside another body sees it at 0
        for e in range(k):
            f = (e + 1) % k
            ax, ay = body_xy[b, e, 0], body_xy[b, e, 1]
            bx, by = body_xy[b, f, 0], body_xy[b, f, 1]
            # only edges facing the sensor can hold the nearest point of a convex body
            if (bx - ax) * (py - ay) - (by - ay) * (px - ax) <= 0.0:
                d = min(d, _wedge(px, py, lx, ly, rx, ry, ax, ay, bx, by))
    if d > 0.0 and in_walls(w, px, py):
        d = 0.0  # a mounting point inside a wall sees distance 0 (even-odd rule over its edges)
    return d if d <= rng[i] else math.inf


def warm_up() -> None:
    """Compiles the kernel now (or loads it from the cache), so the first tick is not slow."""
    scene = Scene(Lab("warm-up", 4.0, 4.0, (Wall(((1.0, 1.0), (2.0, 1.0), (2.0, 2.0)), 1.0),)))
    one = np.zeros(1)
    cone_distances(
        scene,
        one + 0.5,
        one + 0.5,
        np.asarray([[0.0, 1.0, 0.0, -1.0]]),
        one + 1.0,
        np.zeros((1, 2)),
        np.ones((1, 2)),
        np.zeros(1, dtype=np.int64),
        np.asarray([[[0.1, 0.1], [0.3, 0.1], [0.3, 0.3], [0.1, 0.3]]]),
    )
