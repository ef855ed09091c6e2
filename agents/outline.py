"""The chair's exact outline on the planning grid, for what the lattice planner cannot see.

The planner (:mod:`iw_zenoh.core.poseplan`) checks the chair at 48 headings 7.5 degrees apart on
5 cm cells, so it is conservative by up to half a heading step and about a cell: a chair that
follows a plan a few degrees off, in a gap that the plan passes with centimetres to spare, can
stand where its real outline touches nothing and yet every lattice state it is in counts as
blocked. Two checks use the exact outline instead:

* :func:`sweeps_onto`: whether a motion brings the outline onto a mapped cell it does not
  already cover (the autopilot's guard, and the short move below).
* :func:`ways_out`: from such a pose, the short motions (a turn on the spot to a neighbouring
  heading step, a few centimetres along the heading) that end on lattice poses, nearest first,
  so that a plan can start from one of them instead of failing for good.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from iw_zenoh.core.posespace import NH

__all__ = ["arc_poses", "sweeps_onto", "ways_out"]

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]

HEADING_STEP_RAD = 2 * math.pi / NH  # the lattice's heading step
OUT_TURN_STEPS = 2  # a way out turns to at most this many heading steps either side (15 degrees)
OUT_SHIFTS_M = (0.05, -0.05, 0.1, -0.1)  # and moves at most this far along the heading first
TURN_COST_M_PER_RAD = 0.3  # nearness of a way out: a radian of turning counts as this much moving
SAMPLE_RAD = math.radians(2.0)  # a turn is checked every this much
SAMPLE_M = 0.025  # a move every this far


def arc_poses(pose: tuple[float, float, float], v_mps: float, w_radps: float, duration_s: float, n: int) -> FloatArray:
    """Poses (n, 3) of x, y, heading (rad) along a constant-speed arc, from the start on.

    Args:
        pose: Start (x m, y m, heading rad).
        v_mps: Forward speed.
        w_radps: Turn rate (counter-clockwise positive).
        duration_s: How long the arc runs.
        n: How many poses, both ends included.

    Returns:
        The poses, the first one the start.
    """
    x, y, th = pose
    ts = np.linspace(0.0, duration_s, n)
    if abs(w_radps) < 1e-9:
        return np.column_stack([x + v_mps * ts * math.cos(th), y + v_mps * ts * math.sin(th), np.full(n, th)])
    hs = th + w_radps * ts
    xs = x + v_mps / w_radps * (np.sin(hs) - math.sin(th))
    ys = y - v_mps / w_radps * (np.cos(hs) - math.cos(th))
    return np.column_stack([xs, ys, hs])


def sweeps_onto(grids: Sequence[BoolArray], cell_m: float, outline: FloatArray, poses: FloatArray) -> bool:
    """Whether an outline moved through poses comes onto a mapped cell that it does not cover at
    the first pose (what it already overlaps, it may move off).

    Args:
        grids: Mapped cells (row = y, col = x), all the same shape; a cell is mapped when any
            grid has it. Outside the grids counts as their edge cells.
        cell_m: Cell size.
        outline: Points (K, 2) covering the chair's outline about its centre of movement, in its
            own frame (x ahead), spaced at most half a cell apart.
        poses: (M, 3) x, y, heading (rad), in order; the first is where the chair stands.

    Returns:
        True when some later pose covers a mapped cell the first does not.
    """
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    wx = poses[:, 0, None] + c * outline[None, :, 0] - s * outline[None, :, 1]
    wy = poses[:, 1, None] + s * outline[None, :, 0] + c * outline[None, :, 1]
    rows, cols = grids[0].shape
    rr = np.clip((wy / cell_m).astype(np.int64), 0, rows - 1)
    cc = np.clip((wx / cell_m).astype(np.int64), 0, cols - 1)
    hit = np.zeros(rr.shape, dtype=bool)
    for g in grids:
        hit |= g[rr, cc]  # only the cells under the outline, not the whole grid
    now = set(zip(rr[0][hit[0]].tolist(), cc[0][hit[0]].tolist(), strict=True))
    later = set(zip(rr[1:][hit[1:]].tolist(), cc[1:][hit[1:]].tolist(), strict=True))
    return bool(later - now)


def _motion(pose: tuple[float, float, float], shift_m: float, heading_rad: float) -> FloatArray:
    """Poses (M, 3) of a move ``shift_m`` along the heading, then a turn on the spot to
    ``heading_rad``, sampled finely enough to check."""
    x, y, th = pose
    n = max(2, int(math.ceil(abs(shift_m) / SAMPLE_M)) + 1)
    s = np.linspace(0.0, shift_m, n)
    move = np.column_stack([x + s * math.cos(th), y + s * math.sin(th), np.full(n, th)])
    turn = heading_rad - th
    k = max(2, int(math.ceil(abs(turn) / SAMPLE_RAD)) + 1)
    hs = th + np.linspace(0.0, turn, k)
    spin = np.column_stack([np.full(k, move[-1, 0]), np.full(k, move[-1, 1]), hs])
    return np.vstack([move, spin[1:]])


def ways_out(pose: tuple[float, float, float]) -> list[FloatArray]:
    """Short motions from a pose to lattice poses nearby, nearest first: a turn on the spot to a
    heading step within :data:`OUT_TURN_STEPS` of the heading, or a move of a few centimetres
    along it (ahead or back) and then such a turn.

    Args:
        pose: Where the chair stands (x m, y m, heading rad).

    Returns:
        Each motion as poses (M, 3) from ``pose`` (its first row) to the lattice pose (its last:
        the heading exactly a heading step), unchecked: check them with :func:`sweeps_onto` and
        the configuration space.
    """
    nearest = round(pose[2] / HEADING_STEP_RAD)
    ends = [
        (shift, (nearest + k) * HEADING_STEP_RAD)
        for shift in (0.0, *OUT_SHIFTS_M)
        for k in range(-OUT_TURN_STEPS, OUT_TURN_STEPS + 1)
    ]
    ends.sort(key=lambda e: abs(e[0]) + TURN_COST_M_PER_RAD * abs(e[1] - pose[2]))
    return [_motion(pose, shift, heading) for shift, heading in ends]
