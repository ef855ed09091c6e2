"""Broad-phase helpers in numpy: boxes as arrays, and an R-tree over them (collision uses them;
the proximity cones have their own grid, :mod:`iw_zenoh.core.cones`)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import shapely
from shapely import STRtree

__all__ = ["Boxes", "boxes_tree"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


class Boxes:
    """Axis-aligned boxes as four contiguous (K,) arrays (fast to index one at a time)."""

    __slots__ = ("x0", "x1", "y0", "y1")

    def __init__(self, lo: FloatArray, hi: FloatArray) -> None:
        self.x0 = np.ascontiguousarray(lo[:, 0], dtype=np.float64)
        self.y0 = np.ascontiguousarray(lo[:, 1], dtype=np.float64)
        self.x1 = np.ascontiguousarray(hi[:, 0], dtype=np.float64)
        self.y1 = np.ascontiguousarray(hi[:, 1], dtype=np.float64)

    def __len__(self) -> int:
        return len(self.x0)

    def overlap(self, i: IntArray, other: Boxes, j: IntArray) -> npt.NDArray[np.bool_]:
        """(P,) whether box ``i[p]`` of this set overlaps box ``j[p]`` of ``other``."""
        return np.asarray(
            (self.x0[i] <= other.x1[j])
            & (self.x1[i] >= other.x0[j])
            & (self.y0[i] <= other.y1[j])
            & (self.y1[i] >= other.y0[j]),
            dtype=bool,
        )

    def shapes(self) -> npt.NDArray[np.object_]:
        """The boxes as shapely polygons."""
        return np.asarray(shapely.box(self.x0, self.y0, self.x1, self.y1), dtype=object)


def boxes_tree(boxes: Boxes) -> STRtree:
    """An R-tree over the boxes."""
    return STRtree(boxes.shapes())
