"""Motors and differential-drive kinematics, vectorized over robots.

Two profiles:

* Intellwheels (native): per wheel ``out_n = (1 - curve) * in_n + curve * out_{n-1}``; a power of
  0.15 on both wheels is the robot's MaxSpeed; wheel base = the body's height; exact arc
  integration over the tick.
* Ciber-Rato (legacy): ``out = (0.5 * in + 0.5 * prev) * N(100, MotorsNoise) / 100``; powers are
  lab units per cycle; wheel base 1; the translation uses the *old* heading; the heading is
  wrapped once.

The array functions' arithmetic is compiled, in :mod:`iw_zenoh.core.drive` (the one
implementation the world runs), which this module imports only when one of them is first called:
the agents that import the constants or :func:`powers_for_twist` never load numba.
"""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from types import ModuleType

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

_NO_NOISE = np.zeros((0, 2))  # no rows: no speed noise (the kernels take arrays, never None)


def _drive() -> ModuleType:
    """The compiled kernels (:mod:`iw_zenoh.core.drive`), imported on first use: the light
    agents import MAX_POWER and powers_for_twist from here and must not load numba
    (``tests/test_agent_imports.py``)."""
    return importlib.import_module("iw_zenoh.core.drive")


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
        Clamped powers, the input's shape (a scalar for a scalar).
    """
    d = _drive()
    p = d.floats(power)
    out = np.empty(p.shape)
    d.clamp_into(p.reshape(-1), out.reshape(-1))
    return out if out.ndim else out[()]


def step_motors(out_prev: FloatArray, cmd: FloatArray, curve: FloatArray) -> FloatArray:
    """One tick of the motor filter, ``(1 - curve) * cmd + curve * out_prev``.

    Args:
        out_prev: Previous outputs, shape (N, 2) (left, right), power units.
        cmd: Commanded powers, shape (N, 2); clamped here.
        curve: Acceleration curves, shape (N,).

    Returns:
        New outputs, shape (N, 2), within [-0.15, 0.15].
    """
    d = _drive()
    prev = d.floats(out_prev)
    out = np.empty(prev.shape)
    d.motors_into(prev, d.floats(cmd), d.floats(curve), out)
    return out


def wheel_speeds_mps(out: FloatArray, max_speed_mps: FloatArray) -> FloatArray:
    """Wheel ground speeds from motor outputs: 0.15 is MaxSpeed.

    Args:
        out: Motor outputs, shape (N, 2).
        max_speed_mps: Shape (N,).

    Returns:
        Speeds, shape (N, 2), m/s.
    """
    d = _drive()
    o = d.floats(out)
    speeds = np.empty(o.shape)
    d.speeds_into(o, d.floats(max_speed_mps), speeds)
    return speeds


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
    d = _drive()
    p = d.floats(pose)
    nxt = np.empty(p.shape)
    d.arcs_into(p, d.floats(wheel_mps), d.floats(wheel_base_m), float(dt_s), nxt)
    return nxt


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
    d = _drive()
    p = d.floats(pose)
    nxt, out = np.empty(p.shape), np.empty((len(p), 2))
    noise = _NO_NOISE if speed_noise is None else d.floats(speed_noise)
    d.drive_into(
        p,
        d.floats(out_prev),
        d.floats(cmd),
        d.floats(params.curve),
        d.floats(params.max_speed_mps),
        d.floats(params.wheel_base_m),
        float(dt_s),
        noise,
        nxt,
        out,
    )
    return nxt, out


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
    d = _drive()
    p = d.floats(pose)
    nxt, out = np.empty(p.shape), np.empty((len(p), 2))
    d.ciber_into(p, d.floats(out_prev), d.floats(cmd), d.floats(motor_gain), nxt, out)
    return nxt, out


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
