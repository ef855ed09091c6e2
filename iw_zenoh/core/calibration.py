"""Fitting the motor model to a real chair's log, as the seed did by hand (section 7.2).

A log of a step command (full power from rest) gives speed over time; the model's step response
is ``v(t) = MaxSpeed (1 - curve ** (t / period))``. MaxSpeed is the plateau; the curve is the
least-squares slope of ``ln(1 - v / MaxSpeed)`` against ``t / period`` through the origin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["Fit", "fit_motor", "rise_time_of", "speeds_from_ticks", "step_window"]

FloatArray = npt.NDArray[np.float64]
PLATEAU_SHARE = 0.2  # the last fifth of the log is taken as the top speed
FIT_BAND = (0.05, 0.95)  # fit on the part of the rise between 5 % and 95 % of the top speed


@dataclass(frozen=True)
class Fit:
    """A fitted motor model.

    Attributes:
        max_speed_mps: Top speed.
        curve: Acceleration curve for ticks of ``period_s``.
        period_s: The tick the curve is for.
    """

    max_speed_mps: float
    curve: float
    period_s: float

    def speed(self, t_s: FloatArray) -> FloatArray:
        """The model's step response at times ``t_s``."""
        return np.asarray(
            self.max_speed_mps * (1.0 - self.curve ** (np.asarray(t_s) / self.period_s)), dtype=np.float64
        )


def speeds_from_ticks(t_s: FloatArray, left: FloatArray, right: FloatArray, ticks_per_m: float) -> FloatArray:
    """Linear speed from cumulative encoder ticks (mean of the wheels), one value per sample."""
    dist = 0.5 * (np.asarray(left) + np.asarray(right)) / ticks_per_m
    v = np.gradient(dist, np.asarray(t_s))
    return np.asarray(v, dtype=np.float64)


def step_window(left_cmd: FloatArray, right_cmd: FloatArray) -> tuple[int, int]:
    """The rows of the step to full power in a log of commands (a serial bridge's log).

    The step is the first run of rows commanded at the log's top forward power on both wheels;
    the window starts one row before it (the chair still at rest) and ends where that command
    changes.

    Args:
        left_cmd: Commanded left power per row.
        right_cmd: Commanded right power per row.

    Returns:
        (first row, one past the last row).

    Raises:
        ValueError: The log never commands both wheels forward alike.
    """
    lc, rc = np.asarray(left_cmd, dtype=np.float64), np.asarray(right_cmd, dtype=np.float64)
    both = np.minimum(lc, rc)
    top = float(both.max()) if len(both) else 0.0
    on = (np.abs(lc - top) < 1e-6) & (np.abs(rc - top) < 1e-6)
    if top <= 0 or not on.any():
        raise ValueError("the log never commands both wheels forward alike: no step to fit")
    start = int(np.flatnonzero(on)[0])
    off = np.flatnonzero(~on[start:])
    end = start + int(off[0]) if len(off) else len(on)
    return max(0, start - 1), end


def rise_time_of(t_s: FloatArray, v: FloatArray, top: float, lo: float = 0.1, hi: float = 0.9) -> float:
    """Time from the first sample at ``lo * top`` to the first at ``hi * top``."""
    t = np.asarray(t_s)
    a = np.flatnonzero(np.asarray(v) >= lo * top)
    b = np.flatnonzero(np.asarray(v) >= hi * top)
    if len(a) == 0 or len(b) == 0:
        return math.nan
    return float(t[b[0]] - t[a[0]])


def fit_motor(t_s: FloatArray, v_mps: FloatArray, *, period_s: float = 0.1) -> Fit:
    """Fits MaxSpeed and AccelerationCurve to a step response.

    Args:
        t_s: Sample times from the step (s), increasing.
        v_mps: Measured speeds.
        period_s: The simulator tick the curve is wanted for.

    Raises:
        ValueError: When the log is too short or never speeds up.
    """
    t = np.asarray(t_s, dtype=np.float64) - float(np.asarray(t_s)[0])
    v = np.asarray(v_mps, dtype=np.float64)
    if len(t) < 10:
        raise ValueError(f"a step response needs at least 10 samples, got {len(t)}")
    top = float(np.median(v[-max(2, int(len(v) * PLATEAU_SHARE)) :]))
    if top <= 0:
        raise ValueError("the chair never moved forward in this log")
    frac = v / top
    use = (frac > FIT_BAND[0]) & (frac < FIT_BAND[1]) & (t > 0)
    if use.sum() < 3:
        raise ValueError("too few samples on the rise to fit a curve; log faster or longer")
    x = t[use] / period_s
    y = np.log(1.0 - frac[use])
    slope = float(np.dot(x, y) / np.dot(x, x))
    return Fit(top, float(math.exp(slope)), period_s)
