"""The map model: a lab (walls, beacons, targets), its grid of start poses, and the geometry
built once from them for collision and sensing.

Plain data in, plain data out; the XML loader lives in :mod:`iw_zenoh.maps`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import numpy.typing as npt
import shapely
from shapely import STRtree
from shapely.geometry.base import BaseGeometry

from iw_zenoh.core.spatial import Boxes

__all__ = [
    "BORDER_HEIGHT_M",
    "Beacon",
    "Grid",
    "GridPosition",
    "Lab",
    "Scene",
    "Target",
    "Wall",
    "check_wall",
]

BORDER_HEIGHT_M = 4.0  # Ciber-Rato's implicit border wall is 4 units high
EDGE_EPS_M = 1e-9  # corners this close to the lab's edge count as on it


@dataclass(frozen=True)
class Wall:
    """A wall: a simple polygon with a height.

    Attributes:
        corners: Polygon vertices ``((x, y), ...)`` in metres, at least three, any orientation.
        height_m: Wall height (hides beacons lower than it).
    """

    corners: tuple[tuple[float, float], ...]
    height_m: float = 4.0


@dataclass(frozen=True)
class Beacon:
    """A beacon the beacon sensors point at."""

    x: float
    y: float
    height_m: float = 0.0


@dataclass(frozen=True)
class Target:
    """A circular target (ground) area."""

    x: float
    y: float
    radius_m: float = 2.0


@dataclass(frozen=True)
class GridPosition:
    """A start pose; position ``k`` (from 1) is robot ``k``'s."""

    x: float
    y: float
    dir_deg: float = 0.0


@dataclass(frozen=True)
class Grid:
    """The start poses of a map, in id order."""

    positions: tuple[GridPosition, ...] = ()


@dataclass(frozen=True)
class Lab:
    """A lab: its size, walls, beacons and targets.

    The rectangular border wall of Ciber-Rato is implicit and not in ``walls``.
    """

    name: str = "NO NAMED LAB"
    width_m: float = 16.0
    height_m: float = 16.0
    walls: tuple[Wall, ...] = ()
    beacons: tuple[Beacon, ...] = ()
    targets: tuple[Target, ...] = ()

    def with_walls(self, extra: tuple[Wall, ...]) -> Lab:
        """Returns a copy with ``extra`` walls appended (obstacles added at run time)."""
        return Lab(self.name, self.width_m, self.height_m, self.walls + extra, self.beacons, self.targets)


def check_wall(corners: tuple[tuple[float, float], ...], width_m: float, height_m: float) -> str | None:
    """Says what is wrong with a wall's corners, or ``None`` when they are fine.

    Args:
        corners: The polygon's vertices, metres.
        width_m: Lab width, metres.
        height_m: Lab height, metres.

    Returns:
        A reason a user can act on, or ``None``.
    """
    if len(corners) < 3:
        return f"a wall needs at least 3 corners, this one has {len(corners)}"
    xy = np.asarray(corners, dtype=np.float64)
    if not np.all(np.isfinite(xy)):
        return "a corner is not a finite number"
    poly = shapely.Polygon(xy)
    if not poly.exterior.is_simple:
        return "the wall's outline crosses itself; list its corners in order around the polygon"
    if poly.area <= 0.0:
        return "the corners enclose no area (collinear or repeated points)"
    lo = xy.min(axis=0)
    hi = xy.max(axis=0)
    if lo[0] < -EDGE_EPS_M or lo[1] < -EDGE_EPS_M or hi[0] > width_m + EDGE_EPS_M or hi[1] > height_m + EDGE_EPS_M:
        return (
            f"the wall spans x [{lo[0]:g}, {hi[0]:g}] y [{lo[1]:g}, {hi[1]:g}], "
            f"outside the lab (0..{width_m:g} x 0..{height_m:g})"
        )
    return None


@dataclass(frozen=True, eq=False)
class Scene:
    """Static geometry of a lab, built once and shared by collision and sensors.

    Attributes:
        lab: The lab it was built from.
    """

    lab: Lab
    _cache: dict[str, object] = field(default_factory=dict, repr=False, compare=False)

    @cached_property
    def wall_polygons(self) -> npt.NDArray[np.object_]:
        """Shapely polygons of the walls, border excluded, shape (W,)."""
        return np.asarray([shapely.Polygon(w.corners) for w in self.lab.walls], dtype=object)

    @cached_property
    def wall_heights_m(self) -> npt.NDArray[np.float64]:
        """Wall heights, shape (W,)."""
        return np.asarray([w.height_m for w in self.lab.walls], dtype=np.float64)

    @cached_property
    def border(self) -> BaseGeometry:
        """The border as a closed line (the lab rectangle's outline)."""
        w, h = self.lab.width_m, self.lab.height_m
        return shapely.LinearRing([(0, 0), (w, 0), (w, h), (0, h)])

    @cached_property
    def solid(self) -> npt.NDArray[np.object_]:
        """Everything a body may not overlap: every wall polygon, then the border ring, shape (W+1,)."""
        geoms = np.concatenate([self.wall_polygons, np.asarray([self.border], dtype=object)])
        shapely.prepare(geoms)
        return geoms

    @cached_property
    def solid_tree(self) -> STRtree:
        """An R-tree over :attr:`solid`."""
        return STRtree(self.solid)

    @cached_property
    def segments(self) -> npt.NDArray[np.float64]:
        """Every wall edge and border edge as segments, shape (S, 2, 2): ``[s, end, xy]``."""
        rings = [np.asarray(w.corners, dtype=np.float64) for w in self.lab.walls]
        w, h = self.lab.width_m, self.lab.height_m
        rings.append(np.asarray([(0, 0), (w, 0), (w, h), (0, h)], dtype=np.float64))
        segs = [np.stack([r, np.roll(r, -1, axis=0)], axis=1) for r in rings]
        return np.concatenate(segs, axis=0) if segs else np.zeros((0, 2, 2))

    @cached_property
    def segment_tree(self) -> STRtree:
        """An R-tree over :attr:`segments` (their bounding boxes)."""
        return STRtree(self.segment_boxes.shapes())

    @cached_property
    def segment_boxes(self) -> Boxes:
        """Bounding boxes of :attr:`segments`."""
        return Boxes(self.segments.min(axis=1), self.segments.max(axis=1))

    @cached_property
    def target_array(self) -> npt.NDArray[np.float64]:
        """Targets as (T, 3): x, y, radius."""
        return np.asarray([(t.x, t.y, t.radius_m) for t in self.lab.targets], dtype=np.float64).reshape(-1, 3)

    @cached_property
    def target_tree(self) -> STRtree:
        """An R-tree over the targets' bounding boxes."""
        t = self.target_array
        return STRtree(shapely.box(t[:, 0] - t[:, 2], t[:, 1] - t[:, 2], t[:, 0] + t[:, 2], t[:, 1] + t[:, 2]))

    @cached_property
    def wall_tree(self) -> STRtree:
        """An R-tree over :attr:`wall_polygons` (border excluded), prepared for predicates."""
        shapely.prepare(self.wall_polygons)
        return STRtree(self.wall_polygons)

    @cached_property
    def corners(self) -> npt.NDArray[np.float64]:
        """Every wall vertex, border corners included, shape (C, 2)."""
        return np.ascontiguousarray(self.segments[:, 0, :])

    @cached_property
    def wall_union(self) -> BaseGeometry:
        """The union of every wall polygon, prepared (empty when there are none)."""
        geom = shapely.union_all(self.wall_polygons) if len(self.wall_polygons) else shapely.GeometryCollection()
        shapely.prepare(geom)
        return geom

    def walls_at_least(self, height_m: float) -> BaseGeometry:
        """The union of walls at least ``height_m`` high, prepared.

        The border is left out: a line between two points of the lab never crosses it.
        """
        key = f"tall:{height_m!r}"
        got = self._cache.get(key)
        if got is None:
            parts = [p for p, hh in zip(self.wall_polygons, self.wall_heights_m, strict=True) if hh >= height_m]
            geom = shapely.union_all(parts) if parts else shapely.GeometryCollection()
            shapely.prepare(geom)
            self._cache[key] = geom
            got = geom
        assert isinstance(got, BaseGeometry)
        return got

    @cached_property
    def free_space(self) -> BaseGeometry:
        """The lab rectangle minus every wall: where a body may be."""
        box = shapely.box(0.0, 0.0, self.lab.width_m, self.lab.height_m)
        if len(self.wall_polygons) == 0:
            return box
        return shapely.difference(box, self.wall_union)


def tile_lab(lab: Lab, cols: int, rows: int, *, name: str | None = None) -> Lab:
    """Repeats a lab as a ``cols`` x ``rows`` grid of wings (for scale tests and benchmarks).

    Each copy keeps its walls, beacons and targets, shifted by whole lab sizes. No wall is added
    between wings: the wings of a floor open into each other.

    Args:
        lab: One wing.
        cols: Copies along x, >= 1.
        rows: Copies along y, >= 1.
        name: The new lab's name (default: the wing's name with the grid size).

    Returns:
        A lab of ``cols * width`` by ``rows * height``.
    """
    walls: list[Wall] = []
    beacons: list[Beacon] = []
    targets: list[Target] = []
    for r in range(rows):
        for c in range(cols):
            dx, dy = c * lab.width_m, r * lab.height_m
            walls += [Wall(tuple((x + dx, y + dy) for x, y in w.corners), w.height_m) for w in lab.walls]
            beacons += [Beacon(b.x + dx, b.y + dy, b.height_m) for b in lab.beacons]
            targets += [Target(t.x + dx, t.y + dy, t.radius_m) for t in lab.targets]
    return Lab(
        name or f"{lab.name} x{cols}x{rows}",
        cols * lab.width_m,
        rows * lab.height_m,
        tuple(walls),
        tuple(beacons),
        tuple(targets),
    )
