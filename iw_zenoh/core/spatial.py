"""Broad-phase helpers in numpy: ragged ranges and box-overlap pairing.

The narrow phase (exact distances, exact polygon tests) is done by the callers on the few pairs
these helpers leave.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import shapely
from shapely import STRtree

__all__ = ["Boxes", "SlotBoxes", "boxes_tree", "robot_item_pairs"]

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


class SlotBoxes:
    """Boxes of the sensors of N robots laid out as (N, S) slots, S the most any robot has.

    Empty slots hold an inverted box that overlaps nothing.

    Args:
        lo: (M, 2) lower corners, one per sensor.
        hi: (M, 2) upper corners.
        slots: (N, S) sensor index of each slot, -1 for an empty slot.
    """

    __slots__ = ("slots", "x0", "x1", "y0", "y1")

    def __init__(self, lo: FloatArray, hi: FloatArray, slots: IntArray) -> None:
        self.slots = slots
        empty = slots < 0
        safe = np.where(empty, 0, slots)
        self.x0 = np.where(empty, np.inf, lo[safe, 0])
        self.y0 = np.where(empty, np.inf, lo[safe, 1])
        self.x1 = np.where(empty, -np.inf, hi[safe, 0])
        self.y1 = np.where(empty, -np.inf, hi[safe, 1])


def robot_item_pairs(
    tree: STRtree, items: Boxes, robot_shapes: npt.NDArray[np.object_], sensors: SlotBoxes
) -> tuple[IntArray, IntArray]:
    """Pairs of (sensor, item) whose boxes overlap, found robot by robot.

    One R-tree query per robot (its box covers all of its sensors) is far cheaper than one per
    sensor; each candidate item is then tested against all of the robot's sensor boxes at once.

    Args:
        tree: An R-tree over ``items``.
        items: The items' boxes.
        robot_shapes: (N,) one box per robot covering all its sensors, as shapely polygons.
        sensors: The sensors' boxes in robot slots.

    Returns:
        ``(sensor, item)`` index arrays.
    """
    rn, it = tree.query(robot_shapes)
    x0 = items.x0[it][:, None]
    x1 = items.x1[it][:, None]
    y0 = items.y0[it][:, None]
    y1 = items.y1[it][:, None]
    hit = (sensors.x0[rn] <= x1) & (sensors.x1[rn] >= x0) & (sensors.y0[rn] <= y1) & (sensors.y1[rn] >= y0)
    q, col = np.nonzero(hit)
    return sensors.slots[rn[q], col], it[q]
