"""Following a planned path, pure: pure pursuit on the planned poses, turning on the spot where
the plan does, backing up where it backs up, and slowing down where it is tight (a careful chair).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["Drive", "backing", "follow", "slowed"]

FloatArray = npt.NDArray[np.float64]

LOOKAHEAD_M = 0.3
TURN_IN_PLACE_DEG = 25.0  # off the plan by more than this (not a planned turn): turn on the spot
CRUISE_MPS = 0.2
BACK_MPS = 0.08  # backing up, slowly (one sensor behind)
SLOW_SHARE = 0.35  # the slowest share of cruise speed, when something is within 0.24 m
TURN_RADPS = 0.35


@dataclass(frozen=True)
class Drive:
    """Wheel speeds asked for, m/s, and why."""

    left_mps: float
    right_mps: float
    status: str


def follow(
    path: FloatArray,
    unwrapped: FloatArray,
    back_at: npt.NDArray[np.bool_],
    index: int,
    pose: tuple[float, float, float],
    *,
    base_m: float,
    careful: bool,
) -> tuple[Drive, int]:
    """One tick of following a plan.

    Args:
        path: The planned poses (N, 3): x, y in m, heading in rad.
        unwrapped: The path's headings unwrapped (N,), rad.
        back_at: For each pose (N,), whether the chair leaves it backwards (:func:`backing`).
        index: The pose reached so far.
        pose: The chair's pose: x, y in m, heading in degrees.
        base_m: The distance between the drive wheels, m.
        careful: Correct deviations by arcs, not turns on the spot (tight floors).

    Returns:
        The drive (status ``replanning`` when the plan is used up short of the goal) and the
        pose now reached.
    """
    x, y, hdg = pose
    p = path
    hu = unwrapped
    i = _progress(p, hu, index, pose)
    th = hu[i] + math.remainder(math.radians(hdg) - hu[i], 2 * math.pi)
    # a turn on the spot ahead: poses at one place, headings changing; do it where planned
    j = i
    while j + 1 < len(p) and math.hypot(p[j + 1, 0] - p[j, 0], p[j + 1, 1] - p[j, 1]) < 1e-6:
        j += 1
    base = base_m
    if j > i or math.hypot(p[i, 0] - x, p[i, 1] - y) < 0.05 and abs(hu[j] - th) > math.radians(8.0):
        err = hu[j] - th
        if abs(err) > math.radians(3.0):
            w = math.copysign(min(TURN_RADPS, 1.5 * abs(err) + 0.05), err)
            return Drive(-w * base / 2, w * base / 2, "turning"), i
    # pure pursuit to a point ahead (behind, backing up), stopping short of the next turn
    # or change of direction
    back = bool(back_at[i])
    k = i
    while (
        k + 1 < len(p)
        and math.hypot(p[k, 0] - x, p[k, 1] - y) < LOOKAHEAD_M
        and abs(hu[k + 1] - hu[i]) < 0.2
        and back_at[k + 1] == back
    ):
        k += 1
    tx, ty = p[k, 0], p[k, 1]
    dist = math.hypot(tx - x, ty - y)
    if dist < 0.03 or (k == len(p) - 1 and dist < 0.1):
        return Drive(0.0, 0.0, "replanning"), i  # the plan is used up short of the goal: plan the rest
    facing = th + math.pi if back else th  # backing up: steer the rear as if it were the front
    err = math.remainder(math.atan2(ty - y, tx - x) - facing, 2 * math.pi)
    return _pursue(err, dist, back, base_m=base, careful=careful), i


def _progress(p: FloatArray, hu: FloatArray, index: int, pose: tuple[float, float, float]) -> int:
    """The nearest path pose ahead of ``index`` (heading counts, so a turn on the spot is
    followed pose by pose)."""
    x, y, hdg = pose
    lo, hi = index, min(len(p), index + 30)
    th = hu[lo] + math.remainder(math.radians(hdg) - hu[lo], 2 * math.pi)
    d2 = (p[lo:hi, 0] - x) ** 2 + (p[lo:hi, 1] - y) ** 2 + (0.3 * (hu[lo:hi] - th)) ** 2
    return lo + int(np.argmin(d2))


def _pursue(err: float, dist: float, back: bool, *, base_m: float, careful: bool) -> Drive:
    """The drive toward a point ``dist`` m away at heading error ``err`` rad (of the rear, backing up)."""
    base = base_m
    if abs(math.degrees(err)) > (45.0 if careful else TURN_IN_PLACE_DEG):
        w = math.copysign(min(TURN_RADPS, 1.5 * abs(err) + 0.05), err)
        return Drive(-w * base / 2, w * base / 2, "turning")
    if back:
        v = BACK_MPS
        w = v * 2.0 * math.sin(err) / max(dist, 0.05)
        return Drive(-(v + w * base / 2), -(v - w * base / 2), "backing")
    v = CRUISE_MPS * min(1.0, 0.3 + dist / LOOKAHEAD_M)
    w = v * 2.0 * math.sin(err) / max(dist, 0.05)
    return Drive(v - w * base / 2, v + w * base / 2, "driving")


def slowed(drive: Drive, dists: list[float | None]) -> Drive:
    """A careful chair slows down where it is tight (a doorway, a chair beside): the follower keeps
    closer.

    Args:
        drive: The drive asked for.
        dists: This tick's readings, m (None: nothing seen).

    Returns:
        The drive scaled down by how near the nearest reading is.
    """
    near = min((d for d in dists if d is not None), default=math.inf)
    k = min(1.0, max(SLOW_SHARE, (near - 0.1) / 0.4))
    return Drive(drive.left_mps * k, drive.right_mps * k, drive.status)


def backing(poses: FloatArray) -> npt.NDArray[np.bool_]:
    """For each pose of a path, whether the chair leaves it backwards (moving against its heading).

    Args:
        poses: The path (N, 3): x, y in m, heading in rad.

    Returns:
        (N,) bool; the last pose False.
    """
    d = np.diff(poses[:, :2], axis=0)
    along = d[:, 0] * np.cos(poses[:-1, 2]) + d[:, 1] * np.sin(poses[:-1, 2])
    return np.append(along < -1e-9, False)
