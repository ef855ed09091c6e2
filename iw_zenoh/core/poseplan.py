"""Planning for a rectangular chair: A* over (x, y, heading).

A chair 1.04 m long that turns about a point near its front axle sweeps far more room than a
disc of its half width: planning it as such a disc (:mod:`iw_zenoh.core.planning`) lets its
corners graze what it passes. Here the configuration space is three-dimensional: for each of
48 headings the walls are grown by the chair's own outline at that heading (a dilation of the
occupancy grid by the rotated rectangle, margin included). A* moves by 0.2 m arcs of five
curvatures (straight included), by turns on the spot of 15 degrees, allowed only when every
intermediate heading is free too (the turn's swept area), or straight back (dearly: a way out
of a tight spot, not a way to travel). Every move is checked against the outline every 5 cm,
and the follower drives what the lattice checked.

Obstacles that the sensors find later are added as occupied cells and dilated the same way, so a
new plan goes round them with the chair's real shape.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import shapely

from iw_zenoh.core.lab import Lab

__all__ = ["PRIMITIVES", "Footprint", "PosePath", "PoseSpace", "occupancy", "pose_plan"]

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]
Point = tuple[float, float]

NH = 48  # headings of the dilated grids (7.5 degrees apart)
STEP_M = 0.2  # arc length of one motion primitive
CURVATURES = (0.0, 1.2, -1.2, 3.0, -3.0)  # 1/m; 3/m is a 0.33 m radius, inside the chair's reach
TURN_BINS = 2  # a turn on the spot turns this many heading bins (15 degrees)
TURN_COST_M = 0.25  # and costs as much as this much driving
CURVE_COST = 0.1  # extra cost per metre per unit of |curvature| (prefer straight)
REVERSE_COST = 3.0  # backing up (straight) costs this many times as much as driving ahead: a
# way out when the chair is wedged, not a way to travel (it has one sensor behind)
SAMPLE_M = 0.05  # check the footprint this often along a primitive


@dataclass(frozen=True)
class Footprint:
    """A chair's outline about its centre of movement, with a safety margin.

    Attributes:
        front_m: From the centre of movement to the front edge.
        rear_m: From the centre of movement to the rear edge (positive).
        half_width_m: Half the size across.
        margin_m: Added on every side.
    """

    front_m: float
    rear_m: float
    half_width_m: float
    margin_m: float = 0.05

    @classmethod
    def of(cls, width_m: float, height_m: float, com: float, margin_m: float = 0.05) -> Footprint:
        """From a spec's Width (length along the heading), Height (across) and COM."""
        return cls(com * width_m, (1.0 - com) * width_m, 0.5 * height_m, margin_m)

    def points(self, step_m: float) -> FloatArray:
        """Points covering the (grown) rectangle at ``step_m`` spacing, edges included, (K, 2)."""
        x0, x1 = -(self.rear_m + self.margin_m), self.front_m + self.margin_m
        h = self.half_width_m + self.margin_m
        xs = np.linspace(x0, x1, max(2, int(math.ceil((x1 - x0) / step_m)) + 1))
        ys = np.linspace(-h, h, max(2, int(math.ceil(2 * h / step_m)) + 1))
        gx, gy = np.meshgrid(xs, ys)
        return np.column_stack([gx.ravel(), gy.ravel()])

    def corners(self, x: float, y: float, heading_rad: float) -> FloatArray:
        """The grown rectangle's corners at a pose, (4, 2)."""
        h = self.half_width_m + self.margin_m
        local = np.array(
            [
                [self.front_m + self.margin_m, -h],
                [self.front_m + self.margin_m, h],
                [-(self.rear_m + self.margin_m), h],
                [-(self.rear_m + self.margin_m), -h],
            ]
        )
        c, s = math.cos(heading_rad), math.sin(heading_rad)
        return np.column_stack([x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]])


def occupancy(lab: Lab, cell_m: float) -> BoolArray:
    """Cells (row = y, col = x) that a wall touches; cells are ``cell_m`` squares from (0, 0)."""
    rows = int(math.ceil(lab.height_m / cell_m))
    cols = int(math.ceil(lab.width_m / cell_m))
    occ = np.zeros((rows, cols), dtype=bool)
    if lab.walls:
        xs = (np.arange(cols) + 0.5) * cell_m
        ys = (np.arange(rows) + 0.5) * cell_m
        gx, gy = np.meshgrid(xs, ys)
        # a cell whose square meets a wall: its centre within half a cell (mitred) of the wall
        walls = shapely.union_all([shapely.Polygon(w.corners) for w in lab.walls])
        grown = shapely.buffer(walls, 0.5 * cell_m, join_style="mitre")
        shapely.prepare(grown)
        occ |= shapely.contains_xy(grown, gx, gy)
    return occ


def _offsets(fp: Footprint, cell_m: float, heading_rad: float) -> npt.NDArray[np.int64]:
    """(drow, dcol) of every cell the footprint covers at a heading, (K, 2), unique."""
    pts = fp.points(0.5 * cell_m)
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    wx = c * pts[:, 0] - s * pts[:, 1]
    wy = s * pts[:, 0] + c * pts[:, 1]
    rc = np.column_stack([np.round(wy / cell_m), np.round(wx / cell_m)]).astype(np.int64)
    return np.unique(rc, axis=0)


class PoseSpace:
    """The three-dimensional configuration space of one footprint over (a window of) an
    occupancy grid.

    Args:
        occ: Occupied cells of the whole lab (row = y, col = x); outside counts as occupied.
        cell_m: Cell size.
        footprint: The chair.
        window: (x0, y0, x1, y1) metres: build only this part (planning stays inside it).
    """

    def __init__(
        self,
        occ: BoolArray,
        cell_m: float,
        footprint: Footprint,
        window: tuple[float, float, float, float] | None = None,
    ) -> None:
        rows, cols = occ.shape
        if window is None:
            r0, c0, r1, c1 = 0, 0, rows, cols
        else:
            x0, y0, x1, y1 = window
            r0, c0 = max(0, int(y0 / cell_m)), max(0, int(x0 / cell_m))
            r1, c1 = min(rows, int(math.ceil(y1 / cell_m))), min(cols, int(math.ceil(x1 / cell_m)))
        self.r0, self.c0 = r0, c0
        self.occ = occ[r0:r1, c0:c1].copy()
        self.cell_m = cell_m
        self.fp = footprint
        self.rows, self.cols = self.occ.shape
        self.offsets = [_offsets(footprint, cell_m, 2 * math.pi * j / NH) for j in range(NH)]
        self.reach = int(max(np.abs(o).max() for o in self.offsets))
        self.blocked = np.zeros((NH, self.rows, self.cols), dtype=bool)
        self._dilate_all()

    def _dilate_all(self) -> None:
        r = self.reach
        padded = np.ones((self.rows + 2 * r, self.cols + 2 * r), dtype=bool)
        padded[r : r + self.rows, r : r + self.cols] = self.occ
        for j, offs in enumerate(self.offsets):
            out = self.blocked[j]
            out[:] = False
            for dr, dc in offs.tolist():
                out |= padded[r + dr : r + dr + self.rows, r + dc : r + dc + self.cols]

    def add_points(self, points: FloatArray) -> int:
        """Marks the cells holding points (K, 2) of (x, y) occupied and grows them into every
        heading; returns how many cells were new."""
        if len(points) == 0:
            return 0
        rr = np.floor(points[:, 1] / self.cell_m).astype(np.int64) - self.r0
        cc = np.floor(points[:, 0] / self.cell_m).astype(np.int64) - self.c0
        ok = (rr >= 0) & (rr < self.rows) & (cc >= 0) & (cc < self.cols)
        cells = np.unique(np.column_stack([rr[ok], cc[ok]]), axis=0)
        if len(cells) == 0:
            return 0
        cells = cells[~self.occ[cells[:, 0], cells[:, 1]]]
        if len(cells) == 0:
            return 0
        self.occ[cells[:, 0], cells[:, 1]] = True
        for j, offs in enumerate(self.offsets):
            # the states whose footprint covers a new cell: the cell minus each offset
            r2 = (cells[:, None, 0] - offs[None, :, 0]).ravel()
            c2 = (cells[:, None, 1] - offs[None, :, 1]).ravel()
            ok2 = (r2 >= 0) & (r2 < self.rows) & (c2 >= 0) & (c2 < self.cols)
            self.blocked[j, r2[ok2], c2[ok2]] = True
        return len(cells)

    def free(self, x: float, y: float, heading_rad: float) -> bool:
        """Whether the chair fits at a pose (at the nearest of the grid's headings)."""
        r = int(y / self.cell_m) - self.r0
        c = int(x / self.cell_m) - self.c0
        if not (0 <= r < self.rows and 0 <= c < self.cols):
            return False
        return not self.blocked[round(heading_rad / (2 * math.pi / NH)) % NH, r, c]

    def path_free(self, poses: FloatArray) -> npt.NDArray[np.bool_]:
        """Which of the poses (K, 3) the chair fits at."""
        if len(poses) == 0:
            return np.zeros(0, dtype=bool)
        r = np.floor(poses[:, 1] / self.cell_m).astype(np.int64) - self.r0
        c = np.floor(poses[:, 0] / self.cell_m).astype(np.int64) - self.c0
        j = np.round(poses[:, 2] / (2 * math.pi / NH)).astype(np.int64) % NH
        inside = (r >= 0) & (r < self.rows) & (c >= 0) & (c < self.cols)
        out = np.zeros(len(poses), dtype=bool)
        out[inside] = ~self.blocked[j[inside], r[inside], c[inside]]
        return out


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
    cell = space.cell_m
    bin_rad = 2 * math.pi / NH
    blocked = space.blocked
    rows, cols, r0, c0 = space.rows, space.cols, space.r0, space.c0
    gx, gy = goal

    def key(x: float, y: float, th: float) -> tuple[int, int, int]:
        return int(x / cell), int(y / cell), round(th / bin_rad) % NH

    wave, wsize = _wavefront(space, goal, reach_m)
    wrows, wcols = wave.shape

    def h_of(x: float, y: float) -> float:
        straight = max(0.0, math.hypot(gx - x, gy - y) - reach_m)
        r = int((y / cell - r0) / COARSE)
        c = int((x / cell - c0) / COARSE)
        if 0 <= r < wrows and 0 <= c < wcols and math.isfinite(wave[r, c]):
            return max(straight, float(wave[r, c] - 2.0) * wsize)
        return straight

    # every primitive's samples at once: (P, S) offsets, and which are turns on the spot
    px = np.stack([q[0][:, 0] for q in PRIMITIVES])
    py = np.stack([q[0][:, 1] for q in PRIMITIVES])
    pt = np.stack([q[0][:, 2] for q in PRIMITIVES])
    costs = [q[1] for q in PRIMITIVES]

    # pose of each node; parent and the primitive's samples to rebuild the path
    poses: list[tuple[float, float, float]] = [start]
    parent: list[int] = [-1]
    via: list[FloatArray | None] = [None]
    best: dict[tuple[int, int, int], float] = {key(*start): 0.0}
    heap: list[tuple[float, float, int]] = [
        (weight * max(0.0, math.hypot(gx - start[0], gy - start[1]) - reach_m), 0.0, 0)
    ]
    expanded = 0
    end = -1
    while heap and expanded < max_expand:
        _, g_now, node = heapq.heappop(heap)
        x, y, th = poses[node]
        if g_now > best.get(key(x, y, th), math.inf):
            continue
        expanded += 1
        if math.hypot(gx - x, gy - y) <= reach_m:
            end = node
            break
        c, s = math.cos(th), math.sin(th)
        wx = x + c * px - s * py
        wy = y + s * px + c * py
        wt = th + pt
        rr = (wy / cell).astype(np.int64) - r0
        cc = (wx / cell).astype(np.int64) - c0
        inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
        jj = np.round(wt / bin_rad).astype(np.int64) % NH
        hit = ~inside
        hit[inside] = blocked[jj[inside], rr[inside], cc[inside]]
        ok = ~hit.any(axis=1)
        for i in np.flatnonzero(ok).tolist():
            nx, ny, nt = float(wx[i, -1]), float(wy[i, -1]), math.remainder(float(wt[i, -1]), 2 * math.pi)
            k = key(nx, ny, nt)
            new = g_now + costs[i]
            if new < best.get(k, math.inf):
                best[k] = new
                poses.append((nx, ny, nt))
                parent.append(node)
                via.append(np.column_stack([wx[i], wy[i], wt[i]]))
                h = h_of(nx, ny)
                heapq.heappush(heap, (new + weight * h, new, len(poses) - 1))
    if end < 0:
        return None
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
    return PosePath(path, expanded)
