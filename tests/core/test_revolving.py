"""A revolving door's geometry: the passage's poses clear the leaves and the drum all the way."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from iw_zenoh.core.geometry import rect_outline, to_world
from iw_zenoh.core.revolving import MID_WHEEL, Drum, drum_walls, profile, ride_pose, to_powers, travel_deg

DRUM = Drum(10.0, 5.0, axis_deg=0.0, radius_m=1.6, wings=3)
LEAF = (DRUM.leaf_m / 0.98, 0.1, 0.98)  # as agents/revolving.py builds them: the hub at the inner end
CLEARANCE_M = 0.1  # at the least, between the chair and a leaf or the drum


def _body(size: tuple[float, float, float], x: float, y: float, deg: float) -> shapely.Polygon:
    w, h, com = size
    corners = rect_outline(np.array([w]), np.array([h]), np.array([com]))
    return shapely.Polygon(to_world(corners, np.array([x]), np.array([y]), np.array([math.radians(deg)]))[0])


def _leaves(turn_deg: float) -> list[shapely.Polygon]:
    return [_body(LEAF, DRUM.hub_x, DRUM.hub_y, DRUM.leaf_heading_deg(k, turn_deg)) for k in range(DRUM.wings)]


def _walls() -> list[shapely.Polygon]:
    return [shapely.Polygon(w) for w in drum_walls(DRUM)]


CHAIR = (MID_WHEEL["width_m"], MID_WHEEL["height_m"], MID_WHEEL["com"])


@pytest.mark.parametrize("side", [1, -1])
def test_a_carried_chair_clears_the_leaves_and_the_drum_all_the_way_round(side: int) -> None:
    start = DRUM.facing_turn_deg(side)
    for done in np.linspace(0.0, 180.0, 181):
        x, y, h = ride_pose(DRUM, side, float(done))
        chair = _body(CHAIR, x, y, h)
        nearest = min(chair.distance(p) for p in _leaves(start + float(done)) + _walls())
        assert nearest > CLEARANCE_M, (side, done, nearest)


@pytest.mark.parametrize("side", [1, -1])
def test_a_chair_turns_on_the_spot_in_its_sector_at_either_end(side: int) -> None:
    travel = travel_deg(DRUM, side)
    for done, (lo, hi) in ((0.0, (travel - 90.0, travel)), (180.0, (travel, travel + 90.0))):
        x, y, _ = ride_pose(DRUM, side, done)
        for h in np.linspace(lo, hi, 46):
            chair = _body(CHAIR, x, y, float(h))
            nearest = min(chair.distance(p) for p in _leaves(DRUM.facing_turn_deg(side) + done) + _walls())
            assert nearest > CLEARANCE_M, (side, done, h, nearest)


@pytest.mark.parametrize("side", [1, -1])
def test_the_way_in_and_out_along_the_axis_is_clear_when_a_sector_faces_it(side: int) -> None:
    travel = travel_deg(DRUM, side)
    for along in np.linspace(-3.0, -DRUM.ring_m, 30):
        x, y = DRUM.point(float(along), side)
        chair = _body(CHAIR, x, y, travel)
        assert min(chair.distance(p) for p in _leaves(DRUM.facing_turn_deg(side)) + _walls()) > CLEARANCE_M
    for along in np.linspace(DRUM.ring_m, 3.0, 30):  # out, after the half turn
        x, y = DRUM.point(float(along), side)
        chair = _body(CHAIR, x, y, travel)
        assert min(chair.distance(p) for p in _leaves(DRUM.facing_turn_deg(side) + 180.0) + _walls()) > CLEARANCE_M


def test_a_sector_faces_each_side_half_a_sector_apart() -> None:
    assert DRUM.faces(0.0, 1)
    assert not DRUM.faces(0.0, -1)
    assert DRUM.faces(60.0, -1)
    assert DRUM.faces(180.0, -1)  # a half turn: the sector that faced one side faces the other
    assert Drum(0.5, 0.5, wings=4).faces(45.0, -1)


def test_the_profile_starts_and_ends_at_rest_and_its_rate_is_its_slope() -> None:
    assert profile(0.0, 180.0, 24.0) == (0.0, 0.0)
    assert profile(24.0, 180.0, 24.0) == (180.0, 0.0)
    (a, rate), (b, _) = profile(11.0, 180.0, 24.0), profile(11.01, 180.0, 24.0)
    assert (b - a) / 0.01 == pytest.approx(rate, rel=1e-3)


def test_the_drum_walls_stay_outside_the_drum_and_leave_the_axis_open() -> None:
    walls = _walls()
    hub = shapely.Point(DRUM.hub_x, DRUM.hub_y)
    assert all(w.distance(hub) >= DRUM.radius_m - 1e-9 for w in walls)
    axis = shapely.LineString([DRUM.point(-3.0, 1), DRUM.point(3.0, 1)]).buffer(0.5)
    assert not any(w.intersects(axis) for w in walls)


def test_powers_turn_on_the_spot_and_stay_within_the_limit() -> None:
    left, right = to_powers(0.0, 0.2, wheel_base_m=0.6, max_speed_mps=0.5)
    assert left == pytest.approx(-right)
    assert right == pytest.approx(0.2 * 0.3 * 0.15 / 0.5)
    assert to_powers(5.0, 0.0, wheel_base_m=0.6, max_speed_mps=0.5) == (0.15, 0.15)


def test_a_drum_with_a_ring_outside_it_is_refused() -> None:
    with pytest.raises(ValueError, match="ring"):
        Drum(1.0, 1.0, radius_m=1.0, ring_m=1.2)
    with pytest.raises(ValueError, match="wings"):
        Drum(1.0, 1.0, wings=2)
