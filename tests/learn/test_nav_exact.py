"""The learner's action and observation maths after their speed-ups (Python clamps, proximity and
laser bounded in one pass) give what the numpy expressions they replaced gave, bit for bit (the
old expressions are kept here as the reference)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from iw_zenoh.core.motor import MAX_POWER
from iw_zenoh.learn.chairnav import default_chair
from iw_zenoh.learn.nav import Goal, Senses, bounded_rows, to_powers

CHAIR = default_chair()
SENSES = Senses(CHAIR, 0.1)
ACTION = st.one_of(
    st.floats(-3.0, 3.0, width=32), st.sampled_from([-0.0, 0.0, 1.0, -1.0, math.nan, math.inf, -math.inf])
)


def _old_to_powers(action: np.ndarray, mode: str) -> tuple[float, float]:
    a = np.clip(np.asarray(action, dtype=np.float64).reshape(2), -1.0, 1.0)
    if mode == "wheels":
        return float(a[0] * MAX_POWER), float(a[1] * MAX_POWER)
    v = a[0] * CHAIR.max_speed_mps
    half_base = 0.5 * CHAIR.height_m
    w = a[1] * CHAIR.max_speed_mps / half_base
    per_mps = MAX_POWER / CHAIR.max_speed_mps
    return float((v - w * half_base) * per_mps), float((v + w * half_base) * per_mps)


def _bits(x: float) -> str:
    return "nan" if x != x else float(x).hex()


@given(st.tuples(ACTION, ACTION), st.sampled_from(["vw", "wheels"]), st.sampled_from(["f32", "f64", "list", "2x1"]))
def test_to_powers_is_the_numpy_clamp_bit_for_bit(action: tuple[float, float], mode: str, given_as: str) -> None:
    """Whatever form the action comes in: the float arrays a policy gives take a shorter path."""
    a = np.asarray(action, dtype=np.float32)
    shaped = {"f32": a, "f64": a.astype(np.float64), "list": a.tolist(), "2x1": a.reshape(2, 1)}[given_as]
    assert [_bits(x) for x in to_powers(shaped, CHAIR, mode)] == [_bits(x) for x in _old_to_powers(a, mode)]  # type: ignore[arg-type]


def _old_vector(prox: np.ndarray, laser: np.ndarray, compass_deg: float, pose: tuple[float, float, float],
                rolled: tuple[float, float], goal: Goal) -> np.ndarray:  # fmt: skip
    s = SENSES
    prox = np.clip(np.where(np.isfinite(prox), prox, s.ir_range), 0.0, s.ir_range)
    laser = np.clip(np.where(np.isfinite(laser), laser, s.laser_range), 0.0, s.laser_range)
    c = math.radians(compass_deg)
    x, y, h = pose
    dist = math.hypot(goal.x - x, goal.y - y)
    bearing = math.atan2(goal.y - y, goal.x - x) - h
    tail = [math.sin(c), math.cos(c), dist, math.sin(bearing), math.cos(bearing),
            rolled[0] / s.period_s, rolled[1] / s.period_s]  # fmt: skip
    return np.clip(np.concatenate([prox, laser, tail]).astype(np.float32), s.lo, s.hi)


SEEN = st.one_of(st.floats(-1.0, 15.0, width=64), st.sampled_from([math.inf, math.nan, -0.0, 0.0]))


@given(
    arrays(np.float64, (len(SENSES.ir_range),), elements=SEEN),
    arrays(np.float64, (len(SENSES.laser_range),), elements=SEEN),
    st.floats(-360.0, 360.0),
    st.tuples(st.floats(-50.0, 50.0), st.floats(-50.0, 50.0), st.floats(-7.0, 7.0)),
    st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)),
)
@settings(max_examples=200)
def test_the_observation_is_the_numpy_one_bit_for_bit(
    prox: np.ndarray, laser: np.ndarray, compass: float, pose: tuple[float, float, float], rolled: tuple[float, float]
) -> None:
    goal = Goal(3.0, -2.0)
    got = SENSES._vector(prox, laser, compass, pose, rolled, goal)
    want = _old_vector(prox, laser, compass, pose, rolled, goal)
    assert got.dtype == want.dtype
    assert got.tobytes() == want.tobytes()


def _old_rows(prox: np.ndarray, laser: np.ndarray, rows: np.ndarray, tail: np.ndarray) -> np.ndarray:
    s = SENSES
    p = np.where(np.isfinite(prox[rows]), prox[rows], s.ir_range)
    b = np.where(np.isfinite(laser[rows]), laser[rows], s.laser_range)
    return np.asarray(np.clip(np.concatenate([p, b, tail], axis=1).astype(np.float32), s.lo, s.hi))


@given(
    st.integers(1, 6).flatmap(
        lambda n: st.tuples(
            arrays(np.float64, (n, len(SENSES.ir_range)), elements=SEEN),
            arrays(np.float64, (n, len(SENSES.laser_range)), elements=SEEN),
            arrays(np.float64, (n, 7), elements=st.one_of(st.floats(-2e3, 2e3), st.sampled_from([math.nan, -0.0]))),
            st.permutations(range(n)),
        )
    )
)
@settings(max_examples=200)
def test_the_vector_environments_observations_are_the_numpy_ones_bit_for_bit(
    parts: tuple[np.ndarray, np.ndarray, np.ndarray, list[int]],
) -> None:
    prox, laser, tail, order = parts
    rows = np.asarray(order, dtype=np.int64)
    got = bounded_rows(prox, laser, rows, SENSES.ranges, tail, SENSES.lo, SENSES.hi)
    want = _old_rows(prox, laser, rows, tail)
    assert got.dtype == want.dtype
    assert got.tobytes() == want.tobytes()


def test_readings_that_do_not_fit_the_chairs_spec_are_refused_not_read_past() -> None:
    s = SENSES
    k, b = len(s.ir_range), len(s.laser_range)
    goal = Goal(3.0, -2.0)
    with pytest.raises(ValueError, match="do not fit"):  # a reading without its laser scan
        s._vector(np.ones(k), np.ones(0), 0.0, (0.0, 0.0, 0.0), (0.0, 0.0), goal)
    with pytest.raises(ValueError, match="do not fit"):  # one proximity value too many
        s._vector(np.ones(k + 1), np.ones(b), 0.0, (0.0, 0.0, 0.0), (0.0, 0.0), goal)
    tail = np.zeros((1, 7))
    with pytest.raises(ValueError, match="do not fit"):
        bounded_rows(np.ones((1, k)), np.ones((1, b + 1)), np.zeros(1, dtype=np.int64), s.ranges, tail, s.lo, s.hi)
    with pytest.raises(ValueError, match="beyond"):
        bounded_rows(np.ones((1, k)), np.ones((1, b)), np.ones(1, dtype=np.int64), s.ranges, tail, s.lo, s.hi)
