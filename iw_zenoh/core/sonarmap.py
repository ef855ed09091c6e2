"""Mapping what proximity cones see (in the manner of Moravec and Elfes' sonar grids).

A cone reading says two things: the nearest thing in the cone is at distance d (somewhere on
the arc at d), and everything in the cone nearer than d is free. Cells inside a cone nearer
than its reading are *carved* free; cells on the arc are *marked* occupied unless a cone has
carved them lately or a known wall is there. Seen from several places, the arcs shrink to the
obstacle. Carving is forgotten after a while so that something that arrives later is mapped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["Cone", "SonarMap"]

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]

_HALF_DIAGONAL = 0.5 * math.sqrt(2.0)  # a cell's half diagonal, in cells


@dataclass(frozen=True)
class Cone:
    """One proximity reading in world coordinates.

    Attributes:
        x: Sensor x.
        y: Sensor y.
        angle_rad: Where it looks.
        half_rad: Half its aperture.
        range_m: Its range.
        distance_m: Its reading, or None for nothing in range.
        mark: Whether the reading may mark its arc (False: it only carves, e.g. when the known
            map already explains it).
    """

    x: float
    y: float
    angle_rad: float
    half_rad: float
    range_m: float
    distance_m: float | None
    mark: bool = True


def _sector_extent(angle_rad: float, half_rad: float, radius: float) -> tuple[float, float, float, float]:
    """The box (min dx, max dx, min dy, max dy) about a cone's origin that holds its sector of
    ``radius``: the apex, the two edges' ends and the arc's points facing an axis."""
    if half_rad >= math.pi:
        return -radius, radius, -radius, radius
    lo, hi = angle_rad - half_rad, angle_rad + half_rad
    quarter = math.pi / 2
    angles = [lo, hi] + [k * quarter for k in range(math.ceil(lo / quarter), math.floor(hi / quarter) + 1)]
    xs = [0.0] + [radius * math.cos(a) for a in angles]
    ys = [0.0] + [radius * math.sin(a) for a in angles]
    return min(xs), max(xs), min(ys), max(ys)


def _window(cone: Cone, reach: float, c: float, rows: int, cols: int) -> tuple[int, int, int, int]:
    """The rows r0:r1 and columns c0:c1 whose cells a cone may carve or mark: the box of its
    sector (a cell beyond its reach or reading, and one cell of margin), within the box of its whole
    circle. Cells outside the sector are never carved nor marked, so the narrow cones a mapping
    chair carries look at a sliver of the cells (the same cells in the same order)."""
    r0 = max(0, int((cone.y - reach) / c) - 1)
    r1 = min(rows, int((cone.y + reach) / c) + 2)
    c0 = max(0, int((cone.x - reach) / c) - 1)
    c1 = min(cols, int((cone.x + reach) / c) + 2)
    far = reach if cone.distance_m is None else max(reach, cone.distance_m)  # an arc lies 0.75 cell about it
    x0, x1, y0, y1 = _sector_extent(cone.angle_rad, cone.half_rad, far + c)
    r0 = max(r0, math.floor((cone.y + y0) / c) - 1)
    r1 = min(r1, math.floor((cone.y + y1) / c) + 2)
    c0 = max(c0, math.floor((cone.x + x0) / c) - 1)
    c1 = min(c1, math.floor((cone.x + x1) / c) + 2)
    return r0, r1, c0, c1


class SonarMap:
    """Obstacles found by cones, on the lab's grid.

    Args:
        known: Cells of the known walls (row = y, col = x).
        cell_m: Cell size.
        mark_m: Only readings nearer than this mark (far arcs are too wide to say much).
        carve_tol_m: Carve only this much short of a reading (sensor noise).
        forget_ticks: A carved cell may be marked again this many updates later.
        confirm_m: Marks from readings this near are *confirmed* (their arcs are narrow); marks
            from farther are tentative, and a planner may set them aside when they leave no way.
        arc_deg: Mark at most this far either side of a cone's axis (default: the whole arc,
            the honest answer). Wide cones say little: a 60-degree arc a metre off spans a
            corridor, so a chair that maps should carry narrow ones.
    """

    def __init__(
        self,
        known: BoolArray,
        cell_m: float,
        *,
        mark_m: float = 1.5,
        carve_tol_m: float = 0.06,
        forget_ticks: int = 50,
        arc_deg: float = 180.0,
        confirm_m: float = 1.5,
    ) -> None:
        self.cell_m = cell_m
        self.rows, self.cols = known.shape
        # known walls, grown by two cells: a wall seen at the edge of a cone is not news
        rows, cols = known.shape
        padded = np.zeros((rows + 4, cols + 4), dtype=bool)
        padded[2:-2, 2:-2] = known
        grown = np.zeros_like(known)
        for dr in range(5):
            for dc in range(5):
                grown |= padded[dr : dr + rows, dc : dc + cols]
        self.known = grown
        self.mark_m = mark_m
        self.carve_tol_m = carve_tol_m
        self.forget_ticks = forget_ticks
        self.arc_rad = math.radians(arc_deg)
        self.confirm_m = confirm_m
        self.occupied = np.zeros(known.shape, dtype=bool)
        self.confirmed = np.zeros(known.shape, dtype=bool)  # marked by a near reading (narrow arc)
        self.carved_at = np.full(known.shape, -(10**9), dtype=np.int64)
        self.updates = 0

    def update(self, cones: list[Cone]) -> FloatArray:
        """Adds one tick of readings; returns the centres (K, 2) of cells newly marked."""
        self.updates += 1
        t = self.updates
        c = self.cell_m
        marks: list[tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], bool]] = []
        for cone in cones:
            reach = cone.range_m if cone.distance_m is None else min(cone.distance_m, cone.range_m)
            r0, r1, c0, c1 = _window(cone, reach, c, self.rows, self.cols)
            if r0 >= r1 or c0 >= c1:
                continue
            rr, cc = np.mgrid[r0:r1, c0:c1]
            dx = (cc + 0.5) * c - cone.x
            dy = (rr + 0.5) * c - cone.y
            dist = np.hypot(dx, dy)
            off = np.abs(np.remainder(np.arctan2(dy, dx) - cone.angle_rad + math.pi, 2 * math.pi) - math.pi)
            inside = off <= cone.half_rad - math.radians(2.0)
            carve = inside & (dist < reach - self.carve_tol_m - 0.5 * c)
            self.carved_at[rr[carve], cc[carve]] = t
            self.occupied[rr[carve], cc[carve]] = False
            self.confirmed[rr[carve], cc[carve]] = False
            if cone.mark and cone.distance_m is not None and cone.distance_m <= self.mark_m:
                arc = (off <= min(cone.half_rad, self.arc_rad)) & (np.abs(dist - cone.distance_m) <= 0.75 * c)
                marks.append((rr[arc], cc[arc], cone.distance_m <= self.confirm_m))
        new_r: list[npt.NDArray[np.int64]] = []
        new_c: list[npt.NDArray[np.int64]] = []
        for rr, cc, near in marks:
            ok = (t - self.carved_at[rr, cc] > self.forget_ticks) & ~self.known[rr, cc]
            if near:
                self.confirmed[rr[ok], cc[ok]] = True
            ok &= ~self.occupied[rr, cc]
            self.occupied[rr[ok], cc[ok]] = True
            new_r.append(rr[ok])
            new_c.append(cc[ok])
        if not new_r:
            return np.zeros((0, 2))
        r = np.concatenate(new_r)
        cl = np.concatenate(new_c)
        return np.column_stack([(cl + 0.5) * c, (r + 0.5) * c])

    def nearest(self, cone: Cone) -> float:
        """The distance from a cone's origin to the nearest mapped cell the cone passes through
        (inf: none).

        A cell counts when the cone meets any part of it, not only its centre: a narrow cone
        near a mapped obstacle (5 degrees at 0.3 m is 2.6 cm wide, half a cell) often holds no
        cell centre at all, and its reading would then look like news right beside the marks
        that explain it.
        """
        r, c = np.nonzero(self.occupied)
        if len(r) == 0:
            return math.inf
        dx = (c + 0.5) * self.cell_m - cone.x
        dy = (r + 0.5) * self.cell_m - cone.y
        dist = np.hypot(dx, dy)
        off = np.abs(np.remainder(np.arctan2(dy, dx) - cone.angle_rad + math.pi, 2 * math.pi) - math.pi)
        half_cell = np.arcsin(np.minimum(1.0, _HALF_DIAGONAL * self.cell_m / np.maximum(dist, 1e-9)))
        inside = (off <= cone.half_rad + half_cell) & (dist <= cone.range_m)
        return float(dist[inside].min() - 0.5 * self.cell_m) if inside.any() else math.inf

    def points(self) -> FloatArray:
        """Centres (K, 2) of every occupied cell."""
        r, c = np.nonzero(self.occupied)
        return np.column_stack([(c + 0.5) * self.cell_m, (r + 0.5) * self.cell_m])
