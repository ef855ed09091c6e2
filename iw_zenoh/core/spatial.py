"""Boxes as arrays, for R-trees over a scene's segments (collision and the proximity cones use
their own cell grid: :mod:`iw_zenoh.core.cones`, :mod:`iw_zenoh.core.contact`)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import shapely

__all__ = ["Boxes"]

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

    def shapes(self) -> npt.NDArray[np.object_]:
        """The boxes as shapely polygons."""
        return np.asarray(shapely.box(self.x0, self.y0, self.x1, self.y1), dtype=object)
