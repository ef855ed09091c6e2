"""The chair's exact outline against the planning grid (agents/outline.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from iw_zenoh.agents.outline import HEADING_STEP_RAD, arc_poses, sweeps_onto, ways_out

from iw_zenoh.core.lab import Lab
from iw_zenoh.core.poseplan import Footprint, occupancy
from tests.support.builders import box_wall

CELL_M = 0.05
WALL = occupancy(Lab("wall", 8.0, 4.0, (box_wall(0.0, 0.0, 8.0, 1.0),)), CELL_M)
NONE = np.zeros_like(WALL)
OUTLINE = Footprint.of(1.04, 0.66, 0.81, 0.0).points(0.5 * CELL_M)


def test_an_arc_starts_at_the_pose_and_turns_at_the_rate_asked() -> None:
    poses = arc_poses((1.0, 2.0, 0.5), 0.2, 0.4, 0.3, 4)
    np.testing.assert_allclose(poses[0], [1.0, 2.0, 0.5])
    assert poses[-1, 2] == pytest.approx(0.5 + 0.4 * 0.3)
    straight = arc_poses((1.0, 2.0, 0.0), 0.2, 0.0, 0.5, 3)
    np.testing.assert_allclose(straight[-1], [1.1, 2.0, 0.0])


def test_moving_onto_a_wall_is_caught_and_moving_off_one_is_not() -> None:
    near = (3.0, 1.0 + 0.33 + 0.06, 0.0)  # 6 cm above a wall
    assert sweeps_onto((WALL, NONE), CELL_M, OUTLINE, arc_poses(near, 0.0, -0.5, 0.3, 4))  # front dips
    assert not sweeps_onto((WALL, NONE), CELL_M, OUTLINE, arc_poses(near, 0.2, 0.0, 0.3, 4))  # along it
    inside = (3.0, 1.0 + 0.1976 - 0.03, math.pi / 2)  # facing away, its rear 3 cm into the wall
    assert not sweeps_onto((WALL, NONE), CELL_M, OUTLINE, arc_poses(inside, 0.2, 0.0, 0.3, 4))  # may leave
    assert sweeps_onto((WALL, NONE), CELL_M, OUTLINE, arc_poses(inside, -0.2, 0.0, 0.3, 4))  # not go deeper
    assert sweeps_onto((NONE, WALL), CELL_M, OUTLINE, arc_poses(near, 0.0, -0.5, 0.3, 4))  # any grid counts


def test_the_ways_out_start_at_the_pose_end_on_heading_steps_and_come_nearest_first() -> None:
    pose = (2.0, 3.0, math.radians(-20.6))
    moves = ways_out(pose)
    assert all(np.allclose(m[0], pose) for m in moves)
    ends = [m[-1, 2] / HEADING_STEP_RAD for m in moves]
    np.testing.assert_allclose(ends, np.round(ends), atol=1e-9)
    np.testing.assert_allclose(moves[0][-1], [2.0, 3.0, math.radians(-22.5)])  # the nearest step, on the spot
    assert {round(math.degrees(m[-1, 2]), 1) for m in moves} == {-37.5, -30.0, -22.5, -15.0, -7.5}
    cost = [math.hypot(m[-1, 0] - 2.0, m[-1, 1] - 3.0) + 0.3 * abs(m[-1, 2] - pose[2]) for m in moves]
    assert cost == sorted(cost)  # a radian of turning counts as 0.3 m of moving
    assert max(math.hypot(m[-1, 0] - 2.0, m[-1, 1] - 3.0) for m in moves) == pytest.approx(0.1)
    steps = np.abs(np.diff(np.unwrap(moves[-1][:, 2])))
    assert steps.max() <= math.radians(2.0) + 1e-9  # turns checked finely
