from __future__ import annotations

import math

import pytest
import shapely

from iw_zenoh.core.lab import Lab
from iw_zenoh.core.poseplan import Footprint, PoseSpace, occupancy, pose_plan
from iw_zenoh.maps import load_lab
from tests.support.builders import DEAD_END, box_wall

CHAIR = Footprint.of(1.04, 0.66, 0.81, margin_m=0.04)  # the LIACC prototype
BARE = Footprint.of(1.04, 0.66, 0.81, margin_m=0.0)


def _clearance(lab: Lab, poses: list[tuple[float, float, float]]) -> float:
    walls = shapely.union_all([shapely.Polygon(w.corners) for w in lab.walls])
    return min(walls.distance(shapely.Polygon(BARE.corners(*p))) for p in poses)


def test_the_footprint_is_the_rectangle_about_the_centre_of_movement() -> None:
    fp = Footprint.of(1.0, 0.6, 0.8, margin_m=0.0)
    assert (fp.front_m, fp.rear_m, fp.half_width_m) == (0.8, 0.19999999999999996, 0.3)
    c = fp.corners(0.0, 0.0, math.pi / 2)
    assert max(c[:, 1]) == 0.8  # facing +y, the front is 0.8 ahead
    assert round(min(c[:, 0]), 6) == -0.3


def test_the_chair_fits_a_corridor_lengthwise_but_not_across() -> None:
    # a 0.9 m corridor along x: the 0.66 m wide chair fits facing along it, not across it
    lab = Lab("c", 10.0, 4.0, (box_wall(0, 0, 10, 1.55), box_wall(0, 2.45, 10, 4)))
    space = PoseSpace(occupancy(lab, 0.05), 0.05, CHAIR)
    assert space.free(5.0, 2.0, 0.0)
    assert space.free(5.0, 2.0, math.pi)
    assert not space.free(5.0, 2.0, math.pi / 2)
    assert not space.free(5.0, 1.7, 0.0)  # too near the lower wall


def test_a_path_through_the_liacc_slalom_keeps_the_whole_chair_clear() -> None:
    lab = load_lab("maps/liacc.xml").with_walls((box_wall(17, 6.1, 17.6, 6.4), box_wall(19.4, 5.5, 20, 5.9)))
    space = PoseSpace(occupancy(lab, 0.05), 0.05, CHAIR, window=(7, 2, 25, 10))
    found = pose_plan(space, (10.0, 6.1, 0.0), (20.0, 6.1), reach_m=0.4)
    assert found is not None
    end = found.poses[-1]
    assert math.hypot(end[0] - 20.0, end[1] - 6.1) <= 0.4
    assert min(found.poses[:, 1][(found.poses[:, 0] > 17.0) & (found.poses[:, 0] < 17.6)]) < 5.8  # under A
    assert end[1] > 6.2  # above B
    # every pose, checked exactly (shapely, the bare rectangle): nothing touches
    assert _clearance(lab, [tuple(p) for p in found.poses]) > 0.0


def test_a_disc_planner_would_have_let_the_corners_hit() -> None:
    # the same chair as a disc of its half width fits where its rectangle does not: a turn in a
    # 1.2 m square room is free for the disc but not for the 1.04 m chair turning near its front
    lab = Lab("r", 6.0, 6.0, (box_wall(0, 0, 6, 2.4), box_wall(0, 3.6, 6, 6)))
    space = PoseSpace(occupancy(lab, 0.05), 0.05, CHAIR)
    assert space.free(3.0, 3.0, 0.0)
    assert not space.free(3.0, 3.0, math.pi / 2)


@pytest.mark.slow  # no path is known only after the planner's whole budget (60,000 states)
def test_no_path_through_a_closed_door_and_one_once_it_is_open() -> None:
    closed = Lab("l", 10.0, 6.0, (box_wall(4.9, 0, 5.1, 6),))
    space = PoseSpace(occupancy(closed, 0.05), 0.05, CHAIR)
    assert pose_plan(space, (2.0, 3.0, 0.0), (8.0, 3.0)) is None
    opened = Lab("l", 10.0, 6.0, (box_wall(4.9, 0, 5.1, 2.4), box_wall(4.9, 3.6, 5.1, 6)))
    space = PoseSpace(occupancy(opened, 0.05), 0.05, CHAIR)
    found = pose_plan(space, (2.0, 3.0, 0.0), (8.0, 3.0))
    assert found is not None
    assert _clearance(opened, [tuple(p) for p in found.poses]) > 0.0


def test_obstacles_added_later_block_the_states_they_touch() -> None:
    lab = Lab("o", 10.0, 6.0)
    space = PoseSpace(occupancy(lab, 0.05), 0.05, CHAIR)
    assert space.free(5.0, 3.0, 0.0)
    import numpy as np

    assert space.add_points(np.array([[5.7, 3.0]])) == 1  # 0.7 m ahead: under the chair's front
    assert not space.free(5.0, 3.0, 0.0)
    assert space.free(5.0, 3.0, math.pi)  # facing away, the short rear clears it
    assert space.add_points(np.array([[5.7, 3.0]])) == 0  # already known
    found = pose_plan(space, (2.0, 3.0, 0.0), (8.0, 3.0))
    assert found is not None
    assert all(space.path_free(found.poses))


def test_a_chair_nose_in_to_a_dead_end_backs_out() -> None:
    space = PoseSpace(occupancy(DEAD_END, 0.05), 0.05, CHAIR)
    found = pose_plan(space, (4.0, 1.5, 0.0), (1.0, 1.5), reach_m=0.3)
    assert found is not None
    p = found.poses
    step = p[1:, :2] - p[:-1, :2]
    along = step[:, 0] * [math.cos(h) for h in p[:-1, 2]] + step[:, 1] * [math.sin(h) for h in p[:-1, 2]]
    assert (along < -1e-9).sum() * 0.05 >= 1.5  # it backed out of the corridor (2 m deep, less its nose)
    assert all(space.path_free(p))
    assert _clearance(DEAD_END, [tuple(q) for q in p]) > 0.03
