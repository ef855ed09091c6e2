"""The cell grid both compiled narrow phases search: square cells over a lab, items binned into
the cells their bounding boxes touch, and the lab's walls indexed in it once per scene.

The proximity cones (:mod:`iw_zenoh.core.cones`) and the collision check
(:mod:`iw_zenoh.core.contact`) look up candidates here instead of in R-trees; the two
point-in-polygon tests they both need sit beside the wall index they read. Kernels are compiled
with numba and cached next to this file (``cache=True``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from numba import njit

from iw_zenoh.core.lab import Scene

__all__ = [
    "CELL_M",
    "MAX_CELLS",
    "CellGrid",
    "SceneWalls",
    "bin_boxes",
    "cell_range",
    "grid_for",
    "in_convex",
    "in_wall",
    "scene_walls",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

CELL_M = 2.0  # cell side: a 4 m cone's box covers 9-16 cells
MAX_CELLS = 1 << 20  # a very large lab gets larger cells instead
_CACHE_KEY = "cell_grid_walls"  # where a scene keeps its wall index


@dataclass(frozen=True)
class CellGrid:
    """Square cells over a lab (items outside it are binned into its edge cells).

    Attributes:
        x0: Left edge, metres.
        y0: Bottom edge, metres.
        cell: Cell side, metres.
        nx: Columns.
        ny: Rows.
    """

    x0: float
    y0: float
    cell: float
    nx: int
    ny: int


@dataclass(frozen=True)
class SceneWalls:
    """A scene's walls in its cell grid: edges (segments) and whole walls, each as CSR over cells.

    Attributes:
        grid: The cells.
        segs: (S, 4) every wall edge ``ax, ay, bx, by`` (the border's edges come last).
        seg_box: (S, 4) each edge's box ``x0, y0, x1, y1``.
        seg_start: (nx * ny + 1,) CSR offsets of the edges touching each cell.
        seg_items: The edges, cell after cell.
        wall_first: (W,) the first edge of each wall.
        wall_count: (W,) how many edges each wall has.
        wall_box: (W, 4) each wall's box.
        wall_start: CSR offsets of the walls touching each cell.
        wall_items: The walls, cell after cell.
    """

    grid: CellGrid
    segs: FloatArray
    seg_box: FloatArray
    seg_start: IntArray
    seg_items: IntArray
    wall_first: IntArray
    wall_count: IntArray
    wall_box: FloatArray
    wall_start: IntArray
    wall_items: IntArray


def grid_for(width_m: float, height_m: float) -> CellGrid:
    """The cells over a lab of this size: :data:`CELL_M` squares, larger past :data:`MAX_CELLS`.

    Args:
        width_m: Lab width, metres.
        height_m: Lab height, metres.

    Returns:
        A grid from (0, 0) covering the lab.
    """
    cell = max(CELL_M, math.sqrt(max(width_m, 1.0) * max(height_m, 1.0) / MAX_CELLS))
    return CellGrid(0.0, 0.0, cell, max(1, math.ceil(width_m / cell)), max(1, math.ceil(height_m / cell)))


def scene_walls(scene: Scene) -> SceneWalls:
    """The scene's walls binned into cells (built once per scene, then kept in its cache).

    Args:
        scene: The lab's geometry.

    Returns:
        Its wall index.
    """
    got = scene._cache.get(_CACHE_KEY)
    if isinstance(got, SceneWalls):
        return got
    lab = scene.lab
    grid = grid_for(lab.width_m, lab.height_m)
    segs = np.ascontiguousarray(scene.segments.reshape(-1, 4), dtype=np.float64)
    seg_box = np.column_stack(
        [
            np.minimum(segs[:, 0], segs[:, 2]),
            np.minimum(segs[:, 1], segs[:, 3]),
            np.maximum(segs[:, 0], segs[:, 2]),
            np.maximum(segs[:, 1], segs[:, 3]),
        ]
    )
    seg_start, seg_items = bin_boxes(seg_box, grid.x0, grid.y0, grid.cell, grid.nx, grid.ny)
    counts = np.asarray([len(w.corners) for w in lab.walls], dtype=np.int64)
    first = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64) if len(counts) else counts
    wall_box = (
        np.asarray(
            [(*np.min(w.corners, axis=0), *np.max(w.corners, axis=0)) for w in lab.walls],
            dtype=np.float64,
        )
        if lab.walls
        else np.zeros((0, 4))
    )
    wall_start, wall_items = bin_boxes(wall_box, grid.x0, grid.y0, grid.cell, grid.nx, grid.ny)
    walls = SceneWalls(grid, segs, seg_box, seg_start, seg_items, first, counts, wall_box, wall_start, wall_items)
    scene._cache[_CACHE_KEY] = walls
    return walls


@njit(cache=True, nogil=True)
def cell_range(lo: float, hi: float, origin: float, cell: float, n: int) -> tuple[int, int]:  # pragma: no cover
    """First and last cell (clamped to ``0..n-1``) that the interval ``[lo, hi]`` touches."""
    a = int(math.floor((lo - origin) / cell))
    b = int(math.floor((hi - origin) / cell))
    return min(max(a, 0), n - 1), min(max(b, 0), n - 1)


@njit(cache=True, nogil=True)
def bin_boxes(
    box: FloatArray, x0: float, y0: float, cell: float, nx: int, ny: int
) -> tuple[IntArray, IntArray]:  # pragma: no cover
    """CSR of the items whose box (x0, y0, x1, y1) touches each cell."""
    counts = np.zeros(nx * ny + 1, dtype=np.int64)
    for i in range(box.shape[0]):
        ca, cb = cell_range(box[i, 0], box[i, 2], x0, cell, nx)
        ra, rb = cell_range(box[i, 1], box[i, 3], y0, cell, ny)
        for r in range(ra, rb + 1):
            for c in range(ca, cb + 1):
                counts[r * nx + c + 1] += 1
    start = np.cumsum(counts)
    fill = start[:-1].copy()
    items = np.empty(start[-1], dtype=np.int64)
    for i in range(box.shape[0]):
        ca, cb = cell_range(box[i, 0], box[i, 2], x0, cell, nx)
        ra, rb = cell_range(box[i, 1], box[i, 3], y0, cell, ny)
        for r in range(ra, rb + 1):
            for c in range(ca, cb + 1):
                items[fill[r * nx + c]] = i
                fill[r * nx + c] += 1
    return start, items


@njit(cache=True, nogil=True)
def in_convex(px: float, py: float, poly: FloatArray, k: int) -> bool:  # pragma: no cover
    """Whether p is inside (or on) the counter-clockwise convex polygon ``poly[:k]`` (a repeated
    vertex makes an edge of length zero, which never excludes)."""
    for e in range(k):
        f = (e + 1) % k
        ex = poly[f, 0] - poly[e, 0]
        ey = poly[f, 1] - poly[e, 1]
        if ex * (py - poly[e, 1]) - ey * (px - poly[e, 0]) < 0.0:
            return False
    return True


@njit(cache=True, nogil=True)
def in_wall(px: float, py: float, segs: FloatArray, first: int, count: int) -> bool:  # pragma: no cover
    """Whether p is inside the wall whose edges are ``segs[first:first + count]`` (even-odd rule)."""
    odd = False
    for s in range(first, first + count):
        ax, ay, bx, by = segs[s, 0], segs[s, 1], segs[s, 2], segs[s, 3]
        if (ay > py) != (by > py) and px < ax + (py - ay) * (bx - ax) / (by - ay):
            odd = not odd
    return odd
