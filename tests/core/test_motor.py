from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from iw_zenoh.core.motor import (
    MAX_POWER,
    DriveParams,
    integrate_pose,
    rise_time_s,
    step_drive,
    step_drive_ciberrato,
    step_motors,
    ticks_to_fraction,
)

powers = st.floats(-1.0, 1.0, allow_nan=False)
curves = st.floats(0.01, 1.0)


def _params(max_speed: float = 0.5, curve: float = 0.5, base: float = 1.0) -> DriveParams:
    return DriveParams(np.array([max_speed]), np.array([curve]), np.array([base]))


def _ticks_to_reach(curve: float, fraction: float) -> int:
    out = np.zeros((1, 2))
    cmd = np.full((1, 2), MAX_POWER)
    for n in range(1, 1000):
        out = step_motors(out, cmd, np.array([curve]))
        if out[0, 0] >= fraction * MAX_POWER:
            return n
    raise AssertionError("never reached")


@pytest.mark.parametrize(("curve", "seconds"), [(0.8, 2.1), (0.2, 0.3)])
def test_seed_figures_for_99_percent_of_top_speed(curve: float, seconds: float) -> None:
    # the dissertation: with a 100 ms period, curve 0.8 takes about 2.1 s and 0.2 about 0.3 s
    assert _ticks_to_reach(curve, 0.99) * 0.1 == pytest.approx(seconds, abs=0.1)
    assert ticks_to_fraction(curve, 0.99) == _ticks_to_reach(curve, 0.99)


@given(prev=powers, cmd=powers, curve=curves)
def test_motor_output_stays_within_limits_and_moves_toward_the_command(prev: float, cmd: float, curve: float) -> None:
    p = np.clip(prev, -MAX_POWER, MAX_POWER)
    out = step_motors(np.array([[p, p]]), np.array([[cmd, cmd]]), np.array([curve]))[0, 0]
    target = float(np.clip(cmd, -MAX_POWER, MAX_POWER))
    assert -MAX_POWER - 1e-12 <= out <= MAX_POWER + 1e-12
    assert abs(out - target) <= abs(p - target) + 1e-15
    assert min(p, target) - 1e-15 <= out <= max(p, target) + 1e-15


def test_full_power_on_both_wheels_is_max_speed_straight_ahead() -> None:
    pose = np.array([[1.0, 2.0, 0.0]])
    out = np.full((1, 2), MAX_POWER)
    nxt, _ = step_drive(pose, out, np.full((1, 2), MAX_POWER), _params(max_speed=0.8, curve=0.5), 0.1)
    np.testing.assert_allclose(nxt[0], [1.0 + 0.08, 2.0, 0.0], atol=1e-12)


def test_opposite_wheels_turn_in_place_about_the_wheel_axis() -> None:
    pose = np.array([[3.0, 3.0, 0.0]])
    # left back, right forward: counter-clockwise at 2 * v / base
    nxt = integrate_pose(pose, np.array([[-0.5, 0.5]]), np.array([0.5]), 0.1)
    np.testing.assert_allclose(nxt[0], [3.0, 3.0, 0.2], atol=1e-12)


def test_arc_integration_lands_on_the_circle() -> None:
    # radius = base/2 * (r + l)/(r - l); a quarter circle in one step
    v_l, v_r, base = 0.5, 1.5, 1.0
    omega = (v_r - v_l) / base
    dt = (math.pi / 2) / omega
    nxt = integrate_pose(np.array([[0.0, 0.0, 0.0]]), np.array([[v_l, v_r]]), np.array([base]), dt)
    radius = 0.5 * (v_r + v_l) / omega
    np.testing.assert_allclose(nxt[0], [radius, radius, math.pi / 2], atol=1e-12)


@given(st.floats(-50.0, 50.0))
def test_heading_is_normalised(theta: float) -> None:
    nxt = integrate_pose(np.array([[0.0, 0.0, theta]]), np.array([[0.0, 0.0]]), np.array([1.0]), 0.1)
    assert -math.pi <= nxt[0, 2] < math.pi


def test_commands_beyond_the_limit_are_clamped() -> None:
    out = step_motors(np.zeros((1, 2)), np.array([[5.0, -5.0]]), np.array([0.5]))
    np.testing.assert_allclose(out, [[0.075, -0.075]])


def test_ciberrato_profile_reproduces_the_legacy_arithmetic() -> None:
    # fact sheet 7.2-7.3, written out by hand for two cycles
    pose = np.array([[3.0, 11.0, 0.5]])
    out = np.zeros((1, 2))
    cmd = np.array([[0.1, 0.15]])
    gain = np.ones((1, 2))
    expected = pose[0].copy()
    prev = np.zeros(2)
    for _ in range(2):
        pose, out = step_drive_ciberrato(pose, out, cmd, gain)
        o = 0.5 * np.array([0.1, 0.15]) + 0.5 * prev
        lin = (o[1] + o[0]) / 2
        rot = o[1] - o[0]
        expected = np.array(
            [expected[0] + lin * math.cos(expected[2]), expected[1] + lin * math.sin(expected[2]), expected[2] + rot]
        )
        prev = o
    assert pose[0].tolist() == expected.tolist()


def test_ciberrato_motor_noise_multiplies_the_output() -> None:
    _, out = step_drive_ciberrato(np.zeros((1, 3)), np.zeros((1, 2)), np.array([[0.1, 0.1]]), np.array([[1.1, 0.9]]))
    np.testing.assert_allclose(out, [[0.055, 0.045]])


def test_ciberrato_heading_wraps_once() -> None:
    pose = np.array([[0.0, 0.0, math.pi - 0.01]])
    nxt, _ = step_drive_ciberrato(pose, np.array([[-0.15, 0.15]]), np.array([[-0.15, 0.15]]), np.ones((1, 2)))
    assert nxt[0, 2] == pytest.approx(math.pi - 0.01 + 0.3 - 2 * math.pi)


def test_dynamics_experiment_rise_time_matches_the_model_within_one_tick() -> None:
    # seed 7.2: MaxSpeed 0.49 and AccelerationCurve 0.83 (simulated: 1.6 s rise time)
    dt = 0.1
    out = np.zeros((1, 2))
    speeds = []
    for _ in range(100):
        out = step_motors(out, np.full((1, 2), MAX_POWER), np.array([0.83]))
        speeds.append(out[0, 0] / MAX_POWER * 0.49)
    s = np.asarray(speeds)
    t10 = (np.argmax(s >= 0.1 * 0.49) + 1) * dt
    t90 = (np.argmax(s >= 0.9 * 0.49) + 1) * dt
    assert t90 - t10 == pytest.approx(rise_time_s(0.83, dt), abs=dt + 1e-9)
    # the continuous model: ln(0.1 / 0.9) / ln(0.83) ticks; the seed's 1.6 s implies a ~135 ms period
    assert rise_time_s(0.83, dt) == pytest.approx(math.log(0.1 / 0.9) / math.log(0.83) * dt, abs=dt)
