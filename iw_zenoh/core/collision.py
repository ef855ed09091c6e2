"""Collision checks on the *next* poses of every robot of a tick, in one vectorized call.

Native rule (exact polygons):

* A robot hits a wall when its next outline intersects the wall's polygon (a body wholly inside
  a wall counts) or leaves the lab, or when the outline swept from its current to its next pose
  crosses a wall its current outline does not already touch (so a fast body cannot tunnel
  through a thin wall, and a body in contact can still turn or back away).
* Two robots hit each other when their next outlines intersect, or their outlines half-way
  through the tick do and their current ones do not. The rule is symmetric.

Legacy rule (:func:`check_collisions_ciberrato`): Ciber-Rato's distance tests on disc centres.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import shapely

from iw_zenoh.core.geometry import wrap_rad
from iw_zenoh.core.lab import Scene

__all__ = ["Collisions", "check_collisions", "check_collisions_ciberrato", "interpolate_pose"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

LEGACY_RADIUS = 0.5  # Ciber-Rato disc radius
LEGACY_ROBOT_GAP = 1.0  # two discs touch when their centres are closer than this


@dataclass(frozen=True)
class Collisions:
    """What every robot would hit at its next pose.

    Attributes:
        collided: (N,) True for a robot whose next pose collides.
        hit_wall: (N,) True where it is a wall (or the border) that the robot hits.
        hit_robot: (N,) True where it is another robot.
        wall_pairs: (P, 2) ``[robot index, wall index]``; the wall index ``len(lab.walls)`` is the
            border.
        robot_pairs: (Q, 2) ``[i, j]`` robot indices with i < j, each pair once.
    """

    collided: BoolArray
    hit_wall: BoolArray
    hit_robot: BoolArray
    wall_pairs: IntArray
    robot_pairs: IntArray

    @staticmethod
    def none(n: int) -> Collisions:
        """No collision for ``n`` robots."""
        z = np.zeros(n, dtype=bool)
        e = np.zeros((0, 2), dtype=np.int64)
        return Collisions(z, z.copy(), z.copy(), e, e.copy())


def interpolate_pose(a: FloatArray, b: FloatArray, t: float) -> FloatArray:
    """Poses a fraction ``t`` of the way from ``a`` to ``b`` (N, 3), turning the short way."""
    out = a + t * (b - a)
    out[:, 2] = wrap_rad(a[:, 2] + t * wrap_rad(b[:, 2] - a[:, 2]))
    return out


def _f64(a: FloatArray) -> FloatArray:
    return np.ascontiguousarray(a, dtype=np.float64)


def _pairs(tree_query: IntArray) -> IntArray:
    return np.ascontiguousarray(tree_query.T, dtype=np.int64).reshape(-1, 2)


def _union(a: IntArray, b: IntArray, width: int) -> IntArray:
    both = np.concatenate([a, b], axis=0)
    if len(both) == 0:
        return both.reshape(0, 2)
    keys = np.unique(both[:, 0] * width + both[:, 1])
    return np.stack([keys // width, keys % width], axis=1)


_ALL = np.zeros(0, dtype=np.bool_)  # the kernel's "no mask": every robot takes part, none is wall-free


@functools.cache
def _kernel() -> Callable[..., tuple[IntArray, int]]:
    """:func:`iw_zenoh.core.collide.collide`, imported on first use, not with this module: the
    world holds :class:`Collisions` and never loads the kernels (numba)."""
    from iw_zenoh.core.collide import collide

    return collide


def check_collisions(
    scene: Scene,
    outline: FloatArray,
    pose_now: FloatArray,
    pose_next: FloatArray,
    *,
    active: BoolArray | None = None,
    ignore_walls: BoolArray | None = None,
    pass_each_other: bool = False,
) -> Collisions:
    """Checks every robot's next pose against the walls and the other robots.

    Broad phase on the boxes bounding each robot's sweep over the tick, in the cells of a grid;
    exact polygon tests (compiled, :mod:`iw_zenoh.core.contact`) only on the pairs whose boxes
    overlap. Outlines closer than :data:`~iw_zenoh.core.contact.TOUCH_M` touch.

    Args:
        scene: The lab's prebuilt geometry.
        outline: Body outlines in each robot's frame, (N, K, 2).
        pose_now: Current poses, (N, 3).
        pose_next: Proposed poses, (N, 3).
        active: (N,) robots that take part (default all); inactive ones neither hit nor are hit.
        ignore_walls: (N,) robots that pass through walls and the border (doors: they are hung
            in a wall), still hitting robots.
        pass_each_other: Whether two robots that both ignore walls never hit each other either
            (the leaves of a revolving door cross at its hub, two leaves of a double door meet).

    Returns:
        The collisions, by robot index.

    Raises:
        ValueError: The arrays do not have one row per robot (the kernel does not check bounds).
    """
    n = len(pose_now)
    if n == 0:
        return Collisions.none(0)
    act = _ALL if active is None else np.ascontiguousarray(active, dtype=np.bool_)
    free = _ALL if ignore_walls is None else np.ascontiguousarray(ignore_walls, dtype=np.bool_)
    if len(outline) != n or len(pose_next) != n or len(act) not in (0, n) or len(free) not in (0, n):
        raise ValueError("check_collisions: outline, poses, active and ignore_walls need one row per robot")
    # one compiled call: the robots taking part, their outlines now, half-way
    # (interpolate_pose(now, nxt, 0.5)) and next (each to_world's bit for bit), the tests, the flags
    flags = np.empty((3, n), dtype=np.bool_)
    pairs, p = _kernel()(scene, _f64(outline), _f64(pose_now), _f64(pose_next), act, free, pass_each_other, flags)
    return Collisions(flags[0], flags[1], flags[2], pairs[:p], pairs[p:])


def check_collisions_ciberrato(
    scene: Scene,
    pose_now: FloatArray,
    pose_next: FloatArray,
    linear: FloatArray,
    *,
    active: BoolArray | None = None,
) -> Collisions:
    """Ciber-Rato's collision rule, exactly (fact sheet section 7.4).

    A robot hits a wall when its proposed centre is closer than 0.5 to any wall edge (border
    included). Two robots whose proposed centres are closer than 1.0 are each flagged only if
    it moves towards the other's current centre.

    Args:
        scene: The lab.
        pose_now: Current poses (N, 3).
        pose_next: Proposed poses (N, 3).
        linear: (N,) this cycle's linear motion ``(L + R) / 2`` (its sign says forward or back).
        active: (N,) robots that take part (not Removed).

    Returns:
        The collisions; ``robot_pairs`` holds ``[flagged robot, other robot]`` rows here.
    """
    n = len(pose_now)
    act = np.ones(n, dtype=bool) if active is None else np.asarray(active, dtype=bool)
    empty = np.zeros((0, 2), dtype=np.int64)
    if n == 0:
        return Collisions.none(0)
    centres = shapely.points(pose_next[:, :2])
    segs = shapely.linestrings(scene.segments)
    near = _pairs(scene.segment_tree.query(centres, predicate="dwithin", distance=LEGACY_RADIUS))
    if len(near):
        d = shapely.distance(centres[near[:, 0]], segs[near[:, 1]])
        near = near[(d < LEGACY_RADIUS) & act[near[:, 0]]]
    # report the segment's wall: segments are listed wall by wall, the border's four last
    seg_wall = np.repeat(np.arange(len(scene.lab.walls) + 1), [len(w.corners) for w in scene.lab.walls] + [4])
    walls = _union(np.stack([near[:, 0], seg_wall[near[:, 1]]], axis=1), empty, len(scene.lab.walls) + 1)

    diff = pose_next[None, :, :2] - pose_next[:, None, :2]
    close = np.hypot(diff[..., 0], diff[..., 1]) < LEGACY_ROBOT_GAP
    np.fill_diagonal(close, False)
    close &= act[:, None] & act[None, :]
    i, j = np.nonzero(close)
    to_other = pose_now[j, :2] - pose_now[i, :2]
    alpha = np.arctan2(to_other[:, 1], to_other[:, 0])
    delta = np.abs(alpha - pose_now[i, 2])
    ahead = (delta < np.pi / 2) | (delta > 3 * np.pi / 2)
    behind = (delta > np.pi / 2) & (delta < 3 * np.pi / 2)
    v = linear[i]
    towards = ((v > 0) & ahead) | ((v < 0) & behind)
    robot_pairs = np.stack([i[towards], j[towards]], axis=1).astype(np.int64)

    hit_wall = np.zeros(n, dtype=bool)
    hit_wall[walls[:, 0]] = True
    hit_robot = np.zeros(n, dtype=bool)
    hit_robot[robot_pairs[:, 0]] = True
    return Collisions(hit_wall | hit_robot, hit_wall, hit_robot, walls, robot_pairs)
