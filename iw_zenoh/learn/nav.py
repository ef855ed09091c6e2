"""What every learning environment shares: a chair's observation, its action turned into wheel
powers through its own spec, and the reward.

Observation (one flat ``float32`` vector, in this order):

* ``proximity``: each proximity sensor's distance, m, in its spec's order (nothing in range: the
  sensor's range), clipped to ``[0, range]``;
* ``laser``: each laser beam's range, m, scanner by scanner, first beam first (nothing: the
  scanner's range);
* ``compass``: sine and cosine of the (noisy) compass heading;
* ``goal``: distance to the goal, m (at most 1000), and sine and cosine of its bearing relative to the heading;
* ``wheels``: each wheel's ground speed over the last tick, m/s (left, right), within three times
  ``max_speed``.

Action (``Box(-1, 1, (2,))``), by the keyword ``action``:

* ``"vw"``: linear speed as a fraction of the chair's ``max_speed`` and turn rate as a fraction of
  its fastest turn (``2 * max_speed / wheel base``), converted to wheel powers through its spec
  (0.15 on both wheels is ``max_speed``: :mod:`iw_zenoh.core.motor`);
* ``"wheels"``: left and right wheel powers as fractions of 0.15.

Reward each step: ``10 * (distance before - distance after)`` (progress to the goal), ``-0.01``
(time), ``+10`` on reaching the goal, ``-10`` on a collision. An episode terminates on the goal or
a collision, and is truncated after its time limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from gymnasium import spaces
from numba import njit

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.motor import MAX_POWER
from iw_zenoh.core.spec import RobotSpec, default_ir_sensors
from iw_zenoh.messages import SensorReading, WorldState
from iw_zenoh.sim.local import ArrayStep

__all__ = [
    "ACTIONS",
    "Goal",
    "Reward",
    "Senses",
    "bounded_rows",
    "clearance_m",
    "goal_distance",
    "to_powers",
    "to_powers_batch",
]

ACTIONS = ("vw", "wheels")
FARTHEST_M = 1000.0  # the goal's distance is clipped to this (farther than any lab's diagonal)
WHEEL_BOUND = 3.0  # wheel speeds are clipped to this many times max_speed (movement noise may pass it)


@dataclass(frozen=True)
class Goal:
    """Where a chair must go: within ``within`` m of ``(x, y)``."""

    x: float
    y: float
    within: float = 0.5


@dataclass(frozen=True)
class Reward:
    """The reward's terms (see the module doc)."""

    progress: float = 10.0
    time: float = -0.01
    goal: float = 10.0
    collision: float = -10.0


class Senses:
    """One chair's observation vector, laid out from its accepted spec.

    Args:
        spec: The chair's spec as the world accepted it.
        period_s: Simulated time a tick (wheel speeds are distance rolled over it).
    """

    def __init__(self, spec: RobotSpec, period_s: float) -> None:
        irs = spec.ir_sensors or default_ir_sensors(spec.width_m, spec.height_m, spec.com)
        self.ir_range = np.asarray([s.range_m for s in irs], dtype=np.float64)
        self.laser_range = np.concatenate(
            [np.full(las.beams, las.range_m) for las in spec.lasers] or [np.zeros(0)]
        ).astype(np.float64)
        self.period_s = period_s
        self.ranges = np.concatenate([self.ir_range, self.laser_range])  # the proximity and laser part's bounds
        k, b = len(self.ir_range), len(self.laser_range)
        self.size = k + b + 2 + 3 + 2
        self.wheel_max = WHEEL_BOUND * spec.max_speed_mps
        lo = np.concatenate([np.zeros(k + b), [-1, -1, 0, -1, -1, -self.wheel_max, -self.wheel_max]])
        hi = np.concatenate([self.ir_range, self.laser_range, [1, 1, FARTHEST_M, 1, 1, self.wheel_max, self.wheel_max]])
        self.lo, self.hi = lo.astype(np.float32), hi.astype(np.float32)
        self.space = spaces.Box(lo.astype(np.float32), hi.astype(np.float32), dtype=np.float32)

    def observe(self, reading: SensorReading, state: WorldState, index: int, goal: Goal) -> np.ndarray:
        """The observation of the chair at ``index`` of ``state`` from its reading."""
        prox = np.asarray([np.nan if v is None else v for v in reading.proximity_m], dtype=np.float64)
        beams = [np.nan if v is None else v for scan in reading.lasers or [] for v in scan.ranges]
        pose = (state.x[index], state.y[index], state.heading[index])
        rolled = (state.rolled_left[index], state.rolled_right[index])
        return self._vector(prox, np.asarray(beams, dtype=np.float64), reading.compass_deg, pose, rolled, goal)

    def observe_arrays(self, a: ArrayStep, index: int, goal: Goal) -> np.ndarray:
        """The same observation from a tick's arrays (:meth:`LocalWorld.step_arrays`), bit for bit."""
        r = a.readings
        assert r is not None, "observe_arrays needs a sensed tick"
        m_first, m_last, l_first, l_last = _slices(a.bodies)
        prox = r.proximity_m[m_first[index] : m_last[index]]
        laser = r.laser_m[l_first[index] : l_last[index]]
        x, y, h = a.pose[index].tolist()
        rolled = a.rolled_m[index].tolist()
        return self._vector(prox, laser, float(r.compass_deg[index]), (x, y, h), (rolled[0], rolled[1]), goal)

    def _vector(
        self,
        prox: np.ndarray,
        laser: np.ndarray,
        compass_deg: float,
        pose: tuple[float, float, float],
        rolled: tuple[float, float],
        goal: Goal,
    ) -> np.ndarray:
        """The vector from one chair's readings (nothing in range: NaN or inf) and its state."""
        c = math.radians(compass_deg)
        x, y, h = pose
        dist = math.hypot(goal.x - x, goal.y - y)
        bearing = math.atan2(goal.y - y, goal.x - x) - h
        tail = (
            math.sin(c),
            math.cos(c),
            dist,
            math.sin(bearing),
            math.cos(bearing),
            rolled[0] / self.period_s,
            rolled[1] / self.period_s,
        )
        return _bounded(_f64(prox), _f64(laser), self.ranges, tail, self.lo, self.hi)


def _f64(a: np.ndarray) -> np.ndarray:
    return a if a.dtype == np.float64 and a.flags.c_contiguous else np.ascontiguousarray(a, dtype=np.float64)


@njit(cache=True, nogil=True)
def _clip(v: Any, lo: Any, hi: Any) -> Any:  # pragma: no cover (float64 or float32 alike)
    """One value clipped as numpy clips it: the larger of ``v`` and ``lo``, then the smaller of that and ``hi``,
    NaN kept (numpy's ``_NPY_CLIP``: ``a > b ? a : b`` then ``a < b ? a : b``, so -0.0 against 0.0
    gives the bound)."""
    if v != v:
        return v
    m = v if v > lo else lo
    return m if m < hi else hi


@njit(cache=True, nogil=True)
def _bounded(
    prox: np.ndarray, laser: np.ndarray, ranges: np.ndarray, tail: tuple[float, ...], lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:  # pragma: no cover
    """The observation vector in one compiled pass, as the numpy expressions gave it: each reading
    not finite becomes its range, is clipped to ``[0, range]`` (float64), then the vector with the
    tail is cast to float32 and clipped to the observation space's bounds."""
    k, b = prox.shape[0], laser.shape[0]
    if k + b != ranges.shape[0] or k + b + len(tail) != lo.shape[0] or lo.shape != hi.shape:
        raise ValueError("the readings do not fit the chair's observation (its spec's sensor and beam counts)")
    out = np.empty(k + b + len(tail), dtype=np.float32)
    for i in range(k + b):
        v = prox[i] if i < k else laser[i - k]
        r = ranges[i]
        if not np.isfinite(v):
            v = r
        out[i] = _clip(np.float32(_clip(v, 0.0, r)), lo[i], hi[i])
    i = k + b
    for v in tail:
        out[i] = _clip(np.float32(v), lo[i], hi[i])
        i += 1
    return out


@njit(cache=True, nogil=True)
def bounded_rows(
    prox: np.ndarray,
    laser: np.ndarray,
    rows: np.ndarray,
    ranges: np.ndarray,
    tail: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
) -> np.ndarray:  # pragma: no cover
    """Many chairs' observations in one compiled pass (the vector environment's): row ``i`` from
    readings row ``rows[i]`` of (R, k) ``prox`` and (R, b) ``laser``, each reading not finite
    becoming its range, then with row ``i`` of (N, t) ``tail`` cast to float32 and clipped to the
    bounds (what ``np.clip(np.concatenate(...).astype(np.float32), lo, hi)`` gave)."""
    n, k, b, t = rows.shape[0], prox.shape[1], laser.shape[1], tail.shape[1]
    if k + b != ranges.shape[0] or k + b + t != lo.shape[0] or lo.shape != hi.shape or tail.shape[0] != n:
        raise ValueError("the readings do not fit the chair's observation (its spec's sensor and beam counts)")
    if prox.shape[0] != laser.shape[0]:
        raise ValueError("proximity and laser readings of different robot counts")
    for i in range(n):
        if rows[i] < 0 or rows[i] >= prox.shape[0]:
            raise ValueError("a row beyond the readings")
    out = np.empty((n, k + b + t), dtype=np.float32)
    for i in range(n):
        row = rows[i]
        for j in range(k + b):
            v = prox[row, j] if j < k else laser[row, j - k]
            if not np.isfinite(v):
                v = ranges[j]
            out[i, j] = _clip(np.float32(v), lo[j], hi[j])
        for j in range(t):
            out[i, k + b + j] = _clip(np.float32(tail[i, j]), lo[k + b + j], hi[k + b + j])
    return out


@lru_cache(maxsize=8)
def _slices(bodies: Bodies) -> tuple[list[int], list[int], list[int], list[int]]:
    """Where each robot's proximity sensors and laser beams are in a tick's flat readings (once
    per roster: Bodies hash by identity)."""
    robots = np.arange(bodies.n)
    own, beams = bodies.ir_owner, bodies.lasers.beam_owner
    return (
        np.searchsorted(own, robots).tolist(),
        np.searchsorted(own, robots, side="right").tolist(),
        np.searchsorted(beams, robots).tolist(),
        np.searchsorted(beams, robots, side="right").tolist(),
    )


_PAIR = (2,)
_FLOATS = (np.dtype(np.float32), np.dtype(np.float64))


def to_powers(action: np.ndarray, spec: RobotSpec, mode: str) -> tuple[float, float]:
    """Wheel powers (left, right) for an action in ``[-1, 1]^2`` (see the module doc).

    Raises:
        ValueError: An unknown ``mode``.
    """
    # clamped as Python floats: np.clip's value (NaN kept, -0.0 kept) without its wrappers' cost;
    # a float array of two (what a policy gives) straight to floats (float32's are exact in float64)
    if type(action) is np.ndarray and action.shape == _PAIR and action.dtype in _FLOATS:
        a0, a1 = action.tolist()
    else:
        a0, a1 = np.asarray(action, dtype=np.float64).reshape(2).tolist()
    a = (min(max(a0, -1.0), 1.0), min(max(a1, -1.0), 1.0))
    if mode == "wheels":
        return float(a[0] * MAX_POWER), float(a[1] * MAX_POWER)
    if mode != "vw":
        raise ValueError(f"action must be one of {ACTIONS}, got {mode!r}")
    v = a[0] * spec.max_speed_mps
    half_base = 0.5 * spec.height_m  # the wheel base is the body's width across the heading
    w = a[1] * spec.max_speed_mps / half_base  # the fastest turn: wheels at +-max_speed
    per_mps = MAX_POWER / spec.max_speed_mps
    return float((v - w * half_base) * per_mps), float((v + w * half_base) * per_mps)


def to_powers_batch(actions: np.ndarray, spec: RobotSpec, mode: str) -> np.ndarray:
    """(N, 2) wheel powers for (N, 2) actions, each as :func:`to_powers` turns it.

    Raises:
        ValueError: An unknown ``mode``.
    """
    a = np.clip(np.asarray(actions, dtype=np.float64).reshape(-1, 2), -1.0, 1.0)
    if mode == "wheels":
        return a * MAX_POWER
    if mode != "vw":
        raise ValueError(f"action must be one of {ACTIONS}, got {mode!r}")
    v = a[:, 0] * spec.max_speed_mps
    half_base = 0.5 * spec.height_m
    w = a[:, 1] * spec.max_speed_mps / half_base
    per_mps = MAX_POWER / spec.max_speed_mps
    return np.column_stack([(v - w * half_base) * per_mps, (v + w * half_base) * per_mps])


def clearance_m(spec: RobotSpec) -> float:
    """How far a start must be from any wall: the farthest corner of the body from its centre of
    movement (where a start pose puts it), and 0.2 m more."""
    return math.hypot(max(spec.com, 1.0 - spec.com) * spec.width_m, 0.5 * spec.height_m) + 0.2


def goal_distance(state: WorldState, index: int, goal: Goal) -> float:
    """How far the chair at ``index`` is from ``goal``, m."""
    return math.hypot(goal.x - state.x[index], goal.y - state.y[index])
