"""Motors and differential-drive kinematics, vectorized over robots.

Two profiles:

* Intellwheels (native): per wheel ``out_n = (1 - curve) * in_n + curve * out_{n-1}``; a power of
  0.15 on both wheels is the robot's MaxSpeed; wheel base = the body's height; exact arc
  integration over the tick.
* Ciber-Rato (legacy): ``out = (0.5 * in + 0.5 * prev) * N(100, MotorsNoise) / 100``; powers are
  lab units per cycle; wheel base 1; the translation uses the *old* heading; the heading is
  wrapped once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "MAX_POWER",
    "DriveParams",
    "clamp_power",
    "integrate_pose",
    "powers_for_twist",
    "rise_time_s",
    "step_drive",
    "step_drive_ciberrato",
    "step_motors",
    "ticks_to_fraction",
    "wheel_speeds_mps",
]

FloatArray = npt.NDArray[np.float64]

MAX_POWER = 0.15  # Ciber-Rato's motor power limit, kept so its agents still work
STRAIGHT_EPS_RAD = 1e-12  # below this turn per tick, integrate as a straight line
CIBER_WHEEL_BASE = 1.0  # Ciber-Rato: 2 x robot radius


@dataclass(frozen=True)
class DriveParams:
    """Per-robot drive constants, each shape (N,).

    Attributes:
        max_speed_mps: Speed at power 0.15 on both wheels.
        curve: Acceleration curve (motor inertia), in ]0, 1].
        wheel_base_m: Distance between the wheels.
    """

    max_speed_mps: FloatArray
    curve: FloatArray
    wheel_base_m: FloatArray


def clamp_power(power: npt.ArrayLike) -> FloatArray:
    """Clamps motor powers to [-0.15, 0.15]; NaN becomes 0 (a power that does not parse).

    Args:
        power: Powers, any shape.

    Returns:
        Clamped powers.
    """
    p = np.asarray(power, dtype=np.float64)
    # np.where rather than np.nan_to_num (same result once clipped: an infinity becomes the
    # limit either way), which costs several times more on a tick's few robots
    # and minimum(maximum()) rather than np.clip: the same values (clip's ties are at +-0.15 only,
    # where both give 0.15's sign), without np.clip's wrappers, which cost more than the sum
    return np.minimum(np.maximum(np.where(np.isnan(p), 0.0, p), -MAX_POWER), MAX_POWER)


def step_motors(out_prev: FloatArray, cmd: FloatArray, curve: FloatArray) -> FloatArray:
    """One tick of the motor filter, ``(1 - curve) * cmd + curve * out_prev``.

    Args:
        out_prev: Previous outputs, shape (N, 2) (left, right), power units.
        cmd: Commanded powers, shape (N, 2); clamped here.
        curve: Acceleration curves, shape (N,).

    Returns:
        New outputs, shape (N, 2), within [-0.15, 0.15].
    """
    c = np.asarray(curve, dtype=np.float64)[:, None]
    return np.asarray((1.0 - c) * clamp_power(cmd) + c * out_prev, dtype=np.float64)


def wheel_speeds_mps(out: FloatArray, max_speed_mps: FloatArray) -> FloatArray:
    """Wheel ground speeds from motor outputs: 0.15 is MaxSpeed.

    Args:
        out: Motor outputs, shape (N, 2).
        max_speed_mps: Shape (N,).

    Returns:
        Speeds, shape (N, 2), m/s.
    """
    return np.asarray(out * (np.asarray(max_speed_mps)[:, None] / MAX_POWER), dtype=np.float64)


def integrate_pose(pose: FloatArray, wheel_mps: FloatArray, wheel_base_m: FloatArray, dt_s: float) -> FloatArray:
    """Moves differential-drive robots for ``dt_s`` at constant wheel speeds (exact arcs).

    Args:
        pose: (N, 3) of x (m), y (m), heading (rad).
        wheel_mps: (N, 2) left and right wheel speeds.
        wheel_base_m: (N,).
        dt_s: Tick length.

    Returns:
        New poses, (N, 3), heading wrapped into [-pi, pi).
    """
    v = 0.5 * (wheel_mps[:, 0] + wheel_mps[:, 1])
    w = (wheel_mps[:, 1] - wheel_mps[:, 0]) / wheel_base_m
    th = pose[:, 2]
    dth = w * dt_s
    straight = np.abs(dth) < STRAIGHT_EPS_RAD
    safe = np.where(straight, 1.0, dth)
    # chord length of the arc over the heading at its middle
    chord = np.where(straight, v * dt_s, 2.0 * v * dt_s * np.sin(0.5 * dth) / safe)
    mid = th + 0.5 * dth
    out = np.empty_like(pose)
    out[:, 0] = pose[:, 0] + chord * np.cos(mid)
    out[:, 1] = pose[:, 1] + chord * np.sin(mid)
    out[:, 2] = (th + dth + np.pi) % (2.0 * np.pi) - np.pi
    return out


def powers_for_twist(v_mps: float, w_radps: float, max_speed_mps: float, wheel_base_m: float) -> tuple[float, float]:
    """The (left, right) powers whose steady wheel speeds give a body velocity (the inverse of
    :func:`wheel_speeds_mps` and :func:`integrate_pose`); a command beyond the motors' reach is
    scaled down as a whole, so the chair keeps the commanded curvature at its top speed.

    Args:
        v_mps: Forward speed, m/s.
        w_radps: Turn rate, rad/s, counter-clockwise.
        max_speed_mps: The robot's speed at power 0.15.
        wheel_base_m: Distance between the wheels.

    Returns:
        ``(left, right)`` powers within [-0.15, 0.15]; NaN in gives (0, 0).
    """
    if not (math.isfinite(v_mps) and math.isfinite(w_radps)):
        return 0.0, 0.0
    # a huge finite command (1e308) would overflow to inf and then inf/inf = NaN: scaled down as a
    # whole first (the same curvature), so every finite command gives finite powers
    big = max(abs(v_mps), abs(w_radps))
    if big > 1e6:  # still far beyond any chair's reach (so at full power), far from overflowing
        v_mps, w_radps = v_mps / big * 1e6, w_radps / big * 1e6
    half = 0.5 * w_radps * wheel_base_m
    left, right = (v_mps - half) * MAX_POWER / max_speed_mps, (v_mps + half) * MAX_POWER / max_speed_mps
    over = max(abs(left), abs(right)) / MAX_POWER
    if over > 1.0:
        left, right = left / over, right / over
    return left, right


def step_drive(
    pose: FloatArray,
    out_prev: FloatArray,
    cmd: FloatArray,
    params: DriveParams,
    dt_s: float,
    *,
    speed_noise: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray]:
    """One native tick: motor filter, then kinematics.

    Args:
        pose: (N, 3) current poses.
        out_prev: (N, 2) previous motor outputs.
        cmd: (N, 2) commanded powers.
        params: Drive constants.
        dt_s: Tick length, seconds.
        speed_noise: Optional (N, 2) relative noise on the wheel speeds (movement noise), e.g.
            ``std * z``; the motors' own state is not affected by it.

    Returns:
        ``(next_pose, out)``: the proposed poses and the new motor outputs.
    """
    out = step_motors(out_prev, cmd, params.curve)
    speeds = wheel_speeds_mps(out, params.max_speed_mps)
    if speed_noise is not None:
        speeds = speeds * (1.0 + speed_noise)
    return integrate_pose(pose, speeds, params.wheel_base_m, dt_s), out


def step_drive_ciberrato(
    pose: FloatArray, out_prev: FloatArray, cmd: FloatArray, motor_gain: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """One Ciber-Rato cycle, exactly as the legacy simulator computes it.

    Args:
        pose: (N, 3) x, y (lab units), heading (rad).
        out_prev: (N, 2) previous outputs (lab units per cycle).
        cmd: (N, 2) input powers; clamped here.
        motor_gain: (N, 2) multiplicative motor noise, ``N(100, MotorsNoise) / 100`` per motor
            (ones for none).

    Returns:
        ``(next_pose, out)``.
    """
    out = (0.5 * clamp_power(cmd) + 0.5 * out_prev) * motor_gain
    lin = 0.5 * (out[:, 1] + out[:, 0])
    rot = (out[:, 1] - out[:, 0]) / CIBER_WHEEL_BASE
    th = pose[:, 2]
    nxt = np.empty_like(pose)
    nxt[:, 0] = pose[:, 0] + lin * np.cos(th)
    nxt[:, 1] = pose[:, 1] + lin * np.sin(th)
    t = th + rot
    t = np.where(t > np.pi, t - 2.0 * np.pi, t)
    nxt[:, 2] = np.where(t < -np.pi, t + 2.0 * np.pi, t)
    return nxt, np.asarray(out, dtype=np.float64)


def ticks_to_fraction(curve: float, fraction: float) -> int:
    """Ticks a step command takes to bring the motor output to ``fraction`` of it.

    Args:
        curve: Acceleration curve in ]0, 1[.
        fraction: Target fraction in ]0, 1[.

    Returns:
        The smallest n with ``1 - curve**n >= fraction``.
    """
    if curve <= 0.0:
        return 1
    return max(1, math.ceil(math.log(1.0 - fraction) / math.log(curve) - 1e-12))


def rise_time_s(curve: float, dt_s: float, lo: float = 0.1, hi: float = 0.9) -> float:
    """The model's 10 %-90 % rise time for a step command, in seconds (whole ticks).

    Args:
        curve: Acceleration curve in ]0, 1[.
        dt_s: Tick length.
        lo: Lower fraction.
        hi: Upper fraction.

    Returns:
        ``(ticks to hi - ticks to lo) * dt_s``.
    """
    return (ticks_to_fraction(curve, hi) - ticks_to_fraction(curve, lo)) * dt_s
