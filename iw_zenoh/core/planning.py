"""Path planning on the known map, as ViRBot does: walls grown by the chair's radius into a
configuration-space grid, A* over it, the path pruned to the corners that matter; obstacles
the sensors find later are grown into the grid the same way before planning again."""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
import shapely

from iw_zenoh.core.lab import Lab

__all__ = ["Grid2D", "astar", "configuration_space", "mark_obstacles", "nearest_free", "plan", "prune"]

BoolArray = npt.NDArray[np.bool_]
Point = tuple[float, float]
NEIGHBOURS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


@dataclass(frozen=True)
class Grid2D:
    """A configuration-space occupancy grid: ``blocked[row, col]`` for the cell centred at
    ``(col + 0.5) * cell_m, (row + 0.5) * cell_m``."""

    blocked: BoolArray
    cell_m: float

    def cell(self, p: Point) -> tuple[int, int]:
        """The (row, col) holding point p, clipped into the grid."""
        r = min(max(int(p[1] / self.cell_m), 0), self.blocked.shape[0] - 1)
        c = min(max(int(p[0] / self.cell_m), 0), self.blocked.shape[1] - 1)
        return r, c

    def centre(self, rc: tuple[int, int]) -> Point:
        """The centre of a cell."""
        return ((rc[1] + 0.5) * self.cell_m, (rc[0] + 0.5) * self.cell_m)


def configuration_space(lab: Lab, radius_m: float, *, cell_m: float = 0.1) -> Grid2D:
    """The cells where a chair's centre of radius ``radius_m`` would touch a wall or the border."""
    rows = int(math.ceil(lab.height_m / cell_m))
    cols = int(math.ceil(lab.width_m / cell_m))
    xs = (np.arange(cols) + 0.5) * cell_m
    ys = (np.arange(rows) + 0.5) * cell_m
    gx, gy = np.meshgrid(xs, ys)
    blocked = (gx < radius_m) | (gy < radius_m) | (gx > lab.width_m - radius_m) | (gy > lab.height_m - radius_m)
    if lab.walls:
        grown = shapely.buffer(shapely.union_all([shapely.Polygon(w.corners) for w in lab.walls]), radius_m)
        shapely.prepare(grown)
        blocked |= shapely.contains_xy(grown, gx, gy)
    return Grid2D(np.asarray(blocked, dtype=bool), cell_m)


def mark_obstacles(grid: Grid2D, points: list[Point], radius_m: float) -> Grid2D:
    """A copy of the grid with discs of ``radius_m`` around obstacle points blocked."""
    blocked = grid.blocked.copy()
    rows, cols = blocked.shape
    reach = int(math.ceil(radius_m / grid.cell_m))
    for x, y in points:
        r0, c0 = grid.cell((x, y))
        for r in range(max(0, r0 - reach), min(rows, r0 + reach + 1)):
            for c in range(max(0, c0 - reach), min(cols, c0 + reach + 1)):
                cx, cy = grid.centre((r, c))
                if (cx - x) ** 2 + (cy - y) ** 2 <= radius_m**2:
                    blocked[r, c] = True
    return replace(grid, blocked=blocked)


def nearest_free(grid: Grid2D, p: Point, max_m: float = 1.0) -> Point | None:
    """The free cell centre nearest to p within ``max_m``, or None."""
    r0, c0 = grid.cell(p)
    reach = int(math.ceil(max_m / grid.cell_m))
    best: tuple[float, Point] | None = None
    rows, cols = grid.blocked.shape
    for r in range(max(0, r0 - reach), min(rows, r0 + reach + 1)):
        for c in range(max(0, c0 - reach), min(cols, c0 + reach + 1)):
            if not grid.blocked[r, c]:
                q = grid.centre((r, c))
                d = math.hypot(q[0] - p[0], q[1] - p[1])
                if d <= max_m and (best is None or d < best[0]):
                    best = (d, q)
    return best[1] if best else None


def astar(grid: Grid2D, start: Point, goal: Point) -> list[Point] | None:
    """The shortest 8-connected path of free cells from start to goal (cell centres), or None."""
    s, g = grid.cell(start), grid.cell(goal)
    if grid.blocked[s] or grid.blocked[g]:
        return None
    rows, cols = grid.blocked.shape
    open_heap: list[tuple[float, float, tuple[int, int]]] = [(0.0, 0.0, s)]
    came: dict[tuple[int, int], tuple[int, int]] = {}
    cost = {s: 0.0}
    while open_heap:
        _, c_now, cur = heapq.heappop(open_heap)
        if cur == g:
            path = [cur]
            while cur in came:
                cur = came[cur]
                path.append(cur)
            return [grid.centre(rc) for rc in reversed(path)]
        if c_now > cost.get(cur, math.inf):
            continue
        for dr, dc in NEIGHBOURS:
            nr, nc = cur[0] + dr, cur[1] + dc
            if not (0 <= nr < rows and 0 <= nc < cols) or grid.blocked[nr, nc]:
                continue
            if dr and dc and (grid.blocked[cur[0] + dr, cur[1]] or grid.blocked[cur[0], cur[1] + dc]):
                continue  # no cutting corners between two blocked cells
            step = math.sqrt(2.0) if dr and dc else 1.0
            new = c_now + step
            if new < cost.get((nr, nc), math.inf):
                cost[(nr, nc)] = new
                came[(nr, nc)] = cur
                heapq.heappush(open_heap, (new + math.hypot(nr - g[0], nc - g[1]), new, (nr, nc)))
    return None


def _clear(grid: Grid2D, a: Point, b: Point) -> bool:
    n = max(2, int(math.hypot(b[0] - a[0], b[1] - a[1]) / (grid.cell_m / 2)) + 1)
    for t in np.linspace(0.0, 1.0, n):
        if grid.blocked[grid.cell((a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])))]:
            return False
    return True


def prune(grid: Grid2D, path: list[Point]) -> list[Point]:
    """The path's points that the chair must pass: each next one the farthest in clear sight."""
    if len(path) <= 2:
        return path[1:]
    out: list[Point] = []
    i = 0
    while i < len(path) - 1:
        j = len(path) - 1
        while j > i + 1 and not _clear(grid, path[i], path[j]):
            j -= 1
        out.append(path[j])
        i = j
    return out


def plan(grid: Grid2D, start: Point, goal: Point) -> list[Point] | None:
    """Waypoints from start to goal (the goal moved to the nearest free place if it is blocked)."""
    s = start if not grid.blocked[grid.cell(start)] else nearest_free(grid, start, 0.5)
    g = goal if not grid.blocked[grid.cell(goal)] else nearest_free(grid, goal, 1.0)
    if s is None or g is None:
        return None
    path = astar(grid, s, g)
    return prune(grid, path) if path else None
