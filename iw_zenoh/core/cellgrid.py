"""The cell grid the compiled narrow phases search: square cells over a lab, items binned into
the cells their bounding boxes touch, and the lab's walls indexed in it once per scene.

The proximity cones (:mod:`iw_zenoh.core.cones`), the laser scanners (:mod:`iw_zenoh.core.laser`)
and the collision check (:mod:`iw_zenoh.core.contact`) look up candidates here instead of in
R-trees; the point-in-polygon tests they need sit beside the wall index they read. The two
sensor kernels take one :class:`SceneIndex` (walls and this tick's bodies) rather than its
eighteen arrays each. Kernels are compiled with numba and cached next to this file
(``cache=True``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
import shapely
from numba import njit

from iw_zenoh.core.lab import Scene

__all__ = [
    "CELL_M",
    "MAX_CELLS",
    "CellGrid",
    "SceneIndex",
    "SceneWalls",
    "bin_boxes",
    "cell_range",
    "gather",
    "grid_for",
    "in_convex",
    "in_wall",
    "in_walls",
    "scene_index",
    "scene_walls",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

CELL_M = 2.0  # cell side: a 4 m cone's box covers 9-16 cells
MAX_CELLS = 1 << 20  # a very large lab gets larger cells instead
_CACHE_KEY = "cell_grid_walls"  # where a scene keeps its wall index


class CellGrid(NamedTuple):
    """Square cells over a lab (items outside it are binned into its edge cells); a NamedTuple
    so that the compiled kernels take it as it is.

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


class SceneWalls(NamedTuple):
    """A scene's walls in its cell grid: edges (segments) and whole walls, each as CSR over cells
    (a NamedTuple, as :class:`CellGrid`, for the kernels).

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
        seg_side: (S,) which side of each wall edge ``a -> b`` the wall is on: 1.0 its left (a
            wall listed counter-clockwise), -1.0 its right (clockwise); 0.0 on the border's edges
            (the lab's outside is solid, and a real chair's scanner may be out there). A ray from
            outside every wall first meets a wall where it enters it, through an edge with the
            ray's origin on its outer side: the laser's kernel skips the other edges.
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
    seg_side: FloatArray


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
    side = _sides(segs, first, counts)
    walls = SceneWalls(grid, segs, seg_box, seg_start, seg_items, first, counts, wall_box, wall_start, wall_items, side)
    scene._cache[_CACHE_KEY] = walls
    return walls


def _sides(segs: FloatArray, first: IntArray, counts: IntArray) -> FloatArray:
    """:attr:`SceneWalls.seg_side`: each wall's orientation (the sign of its area, the shoelace
    sum over its edges), and 0.0 on the border's edges (the last ones, after every wall's)."""
    side = np.zeros(segs.shape[0])
    for f, c in zip(first.tolist(), counts.tolist(), strict=True):
        e = segs[f : f + c] - np.tile(segs[f, :2], 2)  # from its first corner: no rounding far from the origin
        if shapely.LinearRing(e[:, :2]).is_simple:  # a wall built without the map's checks may cross itself: 0
            side[f : f + c] = np.sign(np.sum(e[:, 0] * e[:, 3] - e[:, 2] * e[:, 1]))
    return side


class SceneIndex(NamedTuple):
    """What the sensors' kernels search, in one value numba takes as it is: the scene's walls
    (built once per scene, :func:`scene_walls`) and the robots' bodies of this tick, binned into
    the same cells. The proximity cones (:mod:`iw_zenoh.core.cones`) and the laser scanners
    (:mod:`iw_zenoh.core.laser`) both take it.

    Attributes:
        walls: The wall index, with its grid.
        body_xy: (N, K, 2) every body's outline in the world, counter-clockwise.
        bbox: (N, 4) each body's box ``x0, y0, x1, y1``.
        b_start: CSR offsets of the bodies touching each cell of ``walls.grid``.
        b_items: The bodies, cell after cell.
    """

    walls: SceneWalls
    body_xy: FloatArray
    bbox: FloatArray
    b_start: IntArray
    b_items: IntArray


def scene_index(scene: Scene, body_xy: FloatArray) -> SceneIndex:
    """The scene's walls (kept per scene) and these bodies, binned into the scene's cells.

    Args:
        scene: The lab's geometry.
        body_xy: (N, K, 2) every body's outline in the world, counter-clockwise.

    Returns:
        The index the sensors' kernels take.
    """
    w = scene_walls(scene)
    g = w.grid
    body_xy = np.ascontiguousarray(body_xy, dtype=np.float64)
    bbox = _boxes(body_xy)
    b_start, b_items = bin_boxes(bbox, g.x0, g.y0, g.cell, g.nx, g.ny)
    return SceneIndex(w, body_xy, bbox, b_start, b_items)


@njit(cache=True, nogil=True)
def _boxes(body_xy: FloatArray) -> FloatArray:  # pragma: no cover
    """(N, 4) each outline's box ``x0, y0, x1, y1`` (the least and greatest of its corners: numpy's
    ``min`` and ``max`` over them, in one call)."""
    n, k = body_xy.shape[0], body_xy.shape[1]
    out = np.empty((n, 4))
    for i in range(n):
        x0, y0 = body_xy[i, 0, 0], body_xy[i, 0, 1]
        x1, y1 = x0, y0
        for e in range(1, k):
            x, y = body_xy[i, e, 0], body_xy[i, e, 1]
            x0, x1 = min(x0, x), max(x1, x)
            y0, y1 = min(y0, y), max(y1, y)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = x0, y0, x1, y1
    return out


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
def gather(
    g: CellGrid,
    start: IntArray,
    items: IntArray,
    item_box: FloatArray,
    seen: IntArray,
    tag: int,
    x0: float,
    y0: float,
    x1: float,
    y1: float,
    out: IntArray,
) -> int:  # pragma: no cover
    """The walk every kernel makes: the items binned (``start``, ``items``: CSR over the cells of
    ``g``) in the cells that the box ``[x0, x1] x [y0, y1]`` touches, each once, whose own box
    (``item_box``, rows ``x0, y0, x1, y1``) overlaps it, written to ``out``; returns how many.

    ``seen`` (one slot an item) marks the items met: an item marked ``tag`` already is skipped,
    and a kernel passes its query's index as the tag, so the marks need no clearing between
    queries. ``out`` has room for every item. The items come in cell order: every kernel's
    answer is the same whatever their order (a minimum, or pairs sorted afterwards).
    """
    n = 0
    ca, cb = cell_range(x0, x1, g.x0, g.cell, g.nx)
    ra, rb = cell_range(y0, y1, g.y0, g.cell, g.ny)
    for r in range(ra, rb + 1):
        for c in range(ca, cb + 1):
            q = r * g.nx + c
            for j in range(start[q], start[q + 1]):
                s = items[j]
                if seen[s] == tag:
                    continue
                seen[s] = tag
                if item_box[s, 0] > x1 or item_box[s, 2] < x0 or item_box[s, 1] > y1 or item_box[s, 3] < y0:
                    continue
                out[n] = s
                n += 1
    return n


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


# inlined where it is called (numba IR): a call passing the SceneWalls tuple cost the cones'
# kernel about 4 % at 1,000 chairs, per sensor, in reference counts
@njit(cache=True, nogil=True, inline="always")
def in_walls(w: SceneWalls, px: float, py: float) -> bool:  # pragma: no cover
    """Whether p is inside any of the scene's walls (a mounting point there sees everything at 0)."""
    if w.wall_box.shape[0] == 0:
        return False
    g = w.grid
    c0, _ = cell_range(px, px, g.x0, g.cell, g.nx)
    r0, _ = cell_range(py, py, g.y0, g.cell, g.ny)
    q = r0 * g.nx + c0
    box = w.wall_box
    for j in range(w.wall_start[q], w.wall_start[q + 1]):
        k = w.wall_items[j]
        if not (box[k, 0] <= px <= box[k, 2] and box[k, 1] <= py <= box[k, 3]):
            continue
        if in_wall(px, py, w.segs, w.wall_first[k], w.wall_count[k]):
            return True
    return False


@njit(cache=True, nogil=True)
def _flat(ix: SceneIndex) -> tuple:  # type: ignore[type-arg]  # pragma: no cover
    """``ix`` as a flat tuple of arrays and numbers (what a parallel loop may take), for :func:`_index`."""
    w, g = ix.walls, ix.walls.grid
    return (
        g.x0, g.y0, g.cell, g.nx, g.ny, w.segs, w.seg_box, w.seg_start, w.seg_items, w.wall_first, w.wall_count,
        w.wall_box, w.wall_start, w.wall_items, w.seg_side, ix.body_xy, ix.bbox, ix.b_start, ix.b_items,
    )  # fmt: skip


@njit(cache=True, nogil=True, inline="always")
def _index(  # type: ignore[no-untyped-def]  # noqa: ANN202, PLR0913
    x0, y0, cell, nx, ny, segs, seg_box, seg_start, seg_items, wall_first, wall_count,
    wall_box, wall_start, wall_items, seg_side, body_xy, bbox, b_start, b_items,
):  # fmt: skip  # noqa: ANN001  # pragma: no cover
    """The :class:`SceneIndex` that :func:`_flat` flattened."""
    w = SceneWalls(
        CellGrid(x0, y0, cell, nx, ny), segs, seg_box, seg_start, seg_items, wall_first, wall_count,
        wall_box, wall_start, wall_items, seg_side,
    )  # fmt: skip
    return SceneIndex(w, body_xy, bbox, b_start, b_items)
