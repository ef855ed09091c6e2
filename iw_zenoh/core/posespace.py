"""The configuration space of a rectangular chair: (x, y, heading) cells where it fits.

A chair 1.04 m long that turns about a point near its front axle sweeps far more room than a
disc of its half width. Here the configuration space is three-dimensional: for each of
:data:`NH` headings the walls are grown by the chair's own outline at that heading (a dilation
of the occupancy grid by the rotated rectangle, margin included). :mod:`iw_zenoh.core.poseplan`
searches it.

Obstacles that the sensors find later are added as occupied cells and dilated the same way, so a
new plan goes round them with the chair's real shape.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import shapely

from iw_zenoh.core.lab import Lab

__all__ = ["NH", "Footprint", "PoseSpace", "occupancy"]

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]

NH = 48  # headings of the dilated grids (7.5 degrees apart)


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
