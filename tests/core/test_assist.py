"""The stick and shared control, pure (iw_zenoh/core/assist.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from iw_zenoh.core.assist import (
    HORIZON_M,
    DriveLimits,
    SharedControl,
    free_path,
    ramp,
    seen_points,
    shifted_path,
    stick_twist,
)
from iw_zenoh.core.spec import IrSensorSpec, prototype_chair

LIM = DriveLimits(max_speed_mps=0.5, max_turn_radps=1.0)
CHAIR = prototype_chair("c")


def test_the_stick_has_a_dead_zone_and_speed_levels() -> None:
    assert stick_twist(0.05, 0.08, 5, LIM) == (0.0, 0.0)
    assert stick_twist(0.0, 1.0, 5, LIM) == pytest.approx((0.5, 0.0))
    assert stick_twist(0.0, 1.0, 1, LIM) == pytest.approx((0.1, 0.0))  # level 1 of 5: a fifth
    assert stick_twist(1.0, 0.0, 5, LIM) == pytest.approx((0.0, -1.0))  # right: clockwise
    assert stick_twist(0.0, -1.0, 5, LIM) == pytest.approx((-0.25, 0.0))  # backwards at half speed
    v, _ = stick_twist(0.0, 0.55, 5, LIM)
    assert v == pytest.approx(0.25)  # proportional past the dead zone


@given(st.floats(), st.floats(), st.integers(-5, 12))
def test_no_stick_drives_beyond_the_chairs_limits(x: float, y: float, level: int) -> None:
    v, w = stick_twist(x, y, level, LIM)
    assert abs(v) <= LIM.max_speed_mps + 1e-9
    assert abs(w) <= LIM.max_turn_radps + 1e-9


def test_the_ramp_speeds_up_at_the_comfort_acceleration_and_slows_twice_as_fast() -> None:
    assert ramp((0.0, 0.0), (0.5, 0.0), 0.1, LIM)[0] == pytest.approx(0.06)
    assert ramp((0.5, 0.0), (0.0, 0.0), 0.1, LIM)[0] == pytest.approx(0.38)


def test_limits_follow_the_chairs_spec() -> None:
    lim = DriveLimits.of(CHAIR)
    assert lim.max_speed_mps == CHAIR.max_speed_mps
    assert 0 < lim.max_turn_radps <= 2 * CHAIR.max_speed_mps / CHAIR.height_m


def test_a_wide_cones_reading_is_points_across_its_whole_cone() -> None:
    spec = prototype_chair("c", ir_sensors=(IrSensorSpec(0, 0.5, 0.0, 0.0, 60.0, 3.0),))
    pts = seen_points(spec, [0], [1.0])
    assert len(pts) >= 12
    np.testing.assert_allclose(np.hypot(pts[:, 0] - 0.5, pts[:, 1]), 1.0)
    assert pts[:, 1].min() == pytest.approx(-0.5)
    assert pts[:, 1].max() == pytest.approx(0.5)
    assert seen_points(spec, [0], [None]).shape == (0, 2)


BOX = (0.8, -0.2, 0.3)  # front, rear, half width


def test_the_free_path_ends_where_the_grown_outline_meets_a_point() -> None:
    wall = np.array([[2.0, y] for y in np.linspace(-1, 1, 41)])
    assert free_path(wall, BOX, 0.3, 0.0, margin_m=0.1) == pytest.approx(2.0 - 0.8 - 0.1, abs=0.03)
    assert free_path(wall, BOX, -0.3, 0.0) == HORIZON_M  # backing away is free
    assert free_path(np.zeros((0, 2)), BOX, 0.3, 0.2) == HORIZON_M


def test_a_chair_too_near_already_may_move_away_but_not_nearer() -> None:
    near = np.array([[0.85, 0.0]])  # 5 cm ahead of the front, inside the margin
    assert free_path(near, BOX, 0.3, 0.0) == 0.0
    assert free_path(near, BOX, -0.3, 0.0) == HORIZON_M


def test_safe_stops_a_full_push_short_of_a_wall_and_says_it_intervened() -> None:
    sc = SharedControl(CHAIR, LIM)
    wall = np.array([[0.97, y] for y in np.linspace(-1, 1, 41)])  # 13 cm ahead of the front
    far = np.array([[6.0, y] for y in np.linspace(-1, 1, 41)])
    assert not sc.step("safe", (0.5, 0.0), far, 0.1, 6.0).intervened
    out = sc.step("safe", (0.5, 0.0), wall, 0.1, 0.3)
    assert out.intervened
    assert 0.0 <= out.v_mps < 0.5
    assert sc.step("off", (0.5, 0.0), wall, 0.1, 0.3).v_mps == 0.5


def test_a_shifted_path_keeps_the_drivers_direction_once_shifted() -> None:
    p = shifted_path(0.3, 0.0, 0.4)
    assert p[-1, 1] == pytest.approx(0.4)
    assert p[-1, 2] == pytest.approx(0.0)
    assert p[0, 1] == pytest.approx(0.0, abs=0.01)


def test_assist_steers_towards_the_free_side_of_an_edge() -> None:
    sc = SharedControl(CHAIR, LIM)
    edge = np.array([[1.8, y] for y in np.linspace(0.1, 1.5, 29)])  # a jamb ahead, on the left
    out = sc.step("assist", (0.3, 0.0), edge, 0.1, 1.0)
    assert out.intervened
    assert out.w_radps < 0.0
    assert math.isfinite(out.v_mps)
    assert out.v_mps > 0.0
