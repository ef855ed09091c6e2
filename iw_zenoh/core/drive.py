"""The drive, compiled: the motor filter, wheel speeds, arc integration, Ciber-Rato's cycle, and
the world's whole propose and commit for N robots, one call each.

Why compiled (numba): a tick of a few robots cost a few dozen small numpy calls in
:func:`iw_zenoh.core.world.propose` (about 100 us for one chair, more than the rest of the world's
tick). Each function performs the numpy expressions' operations in the same order on the same
float64 values (``tests/core/test_drive.py`` keeps those expressions as its oracle and checks the
results bit for bit on random input, NaN and infinities included), with numpy's error model (a
division by zero gives an infinity, as numpy's does). The world process and the in-process world
(:class:`~iw_zenoh.sim.local.LocalWorld`) both run these; the light agents never load them
(:mod:`iw_zenoh.core.motor` imports this module only when one of its array functions is used).
Outputs are allocated here and filled by the kernels (a kernel returning new arrays costs several
microseconds a result). Cached on disk as the other kernels.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from iw_zenoh.core.motor import CIBER_WHEEL_BASE, MAX_POWER, STRAIGHT_EPS_RAD, DriveParams

__all__ = [
    "arcs_into",
    "ciber_into",
    "clamp_into",
    "drive_into",
    "motors_into",
    "speeds_into",
    "REAL",
    "TABLE_COLUMNS",
    "bools",
    "commit_into",
    "floats",
    "propose_into",
    "warm_up",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

# the columns of the (N, 6) per-robot table :func:`propose_into` takes
CURVE, MAX_SPEED, BASE, MEAN, STD, REAL = range(6)
TABLE_COLUMNS = 6
_TWO_PI = 2.0 * math.pi
_F64, _BOOL = np.dtype(np.float64), np.dtype(np.bool_)


@njit(cache=True, nogil=True)
def _rows(a: FloatArray, n: int, k: int) -> None:  # pragma: no cover
    """Raises unless ``a`` is (n, k): the kernels index without bounds checks."""
    if a.shape[0] != n or a.shape[1] != k:
        raise ValueError("an array's shape does not fit the robots' (N, k)")


@njit(cache=True, nogil=True)
def _long(a: npt.NDArray[Any], n: int) -> None:  # pragma: no cover
    """Raises unless ``a`` is (n,)."""
    if a.shape[0] != n:
        raise ValueError("an array's length is not the robots' N")


@njit(cache=True, nogil=True, error_model="numpy")
def _clamp(p: float) -> float:  # pragma: no cover
    """``minimum(maximum(where(isnan(p), 0, p), -0.15), 0.15)``."""
    c = 0.0 if p != p else p
    c = c if c >= -MAX_POWER else -MAX_POWER
    return c if c <= MAX_POWER else MAX_POWER


@njit(cache=True, nogil=True, error_model="numpy")
def _motor(prev: float, cmd: float, curve: float) -> float:  # pragma: no cover
    """One wheel's motor filter: ``(1 - curve) * clamp(cmd) + curve * prev``."""
    return (1.0 - curve) * _clamp(cmd) + curve * prev


@njit(cache=True, nogil=True, error_model="numpy")
def _arc(
    x: float, y: float, th: float, sl: float, sr: float, base: float, dt: float
) -> tuple[float, float, float]:  # pragma: no cover
    """One robot moved ``dt`` at wheel speeds ``sl``, ``sr`` along the exact arc: the chord over
    the heading at the arc's middle, a straight line below a turn of 1e-12 rad."""
    v = 0.5 * (sl + sr)
    w = (sr - sl) / base
    dth = w * dt
    chord = v * dt if abs(dth) < STRAIGHT_EPS_RAD else 2.0 * v * dt * math.sin(0.5 * dth) / dth
    mid = th + 0.5 * dth
    return x + chord * math.cos(mid), y + chord * math.sin(mid), (th + dth + math.pi) % _TWO_PI - math.pi


@njit(cache=True, nogil=True, error_model="numpy")
def _native(
    pose: FloatArray,
    prev: FloatArray,
    cmd: FloatArray,
    i: int,
    curve: float,
    max_speed: float,
    base: float,
    dt: float,
    noisy: bool,
    nl: float,
    nr: float,
    nxt: FloatArray,
    out: FloatArray,
) -> float:  # pragma: no cover
    """Robot ``i``'s native tick into ``nxt[i]`` and ``out[i]``: motor filter, wheel speeds
    (times ``1 + noise`` when ``noisy``), arc; returns the speed scale ``max_speed / 0.15``."""
    ol = _motor(prev[i, 0], cmd[i, 0], curve)
    orr = _motor(prev[i, 1], cmd[i, 1], curve)
    scale = max_speed / MAX_POWER
    sl, sr = ol * scale, orr * scale
    if noisy:
        sl, sr = sl * (1.0 + nl), sr * (1.0 + nr)
    nxt[i, 0], nxt[i, 1], nxt[i, 2] = _arc(pose[i, 0], pose[i, 1], pose[i, 2], sl, sr, base, dt)
    out[i, 0], out[i, 1] = ol, orr
    return scale


@njit(cache=True, nogil=True, error_model="numpy")
def _ciber(
    pose: FloatArray, prev: FloatArray, cmd: FloatArray, i: int, gl: float, gr: float, nxt: FloatArray, out: FloatArray
) -> None:  # pragma: no cover
    """Robot ``i``'s Ciber-Rato cycle into ``nxt[i]`` and ``out[i]``: ``(0.5 * cmd + 0.5 *
    prev) * gain``, the translation along the old heading, the heading wrapped once."""
    ol = (0.5 * _clamp(cmd[i, 0]) + 0.5 * prev[i, 0]) * gl
    orr = (0.5 * _clamp(cmd[i, 1]) + 0.5 * prev[i, 1]) * gr
    lin = 0.5 * (orr + ol)
    rot = (orr - ol) / CIBER_WHEEL_BASE
    th = pose[i, 2]
    nxt[i, 0] = pose[i, 0] + lin * math.cos(th)
    nxt[i, 1] = pose[i, 1] + lin * math.sin(th)
    t = th + rot
    if t > math.pi:
        t = t - _TWO_PI
    if t < -math.pi:
        t = t + _TWO_PI
    nxt[i, 2] = t
    out[i, 0], out[i, 1] = ol, orr


@njit(cache=True, nogil=True, error_model="numpy")
def clamp_into(p: FloatArray, out: FloatArray) -> None:  # pragma: no cover
    """(M,) powers clamped into ``out`` (:func:`iw_zenoh.core.motor.clamp_power`)."""
    _long(out, p.shape[0])
    for k in range(p.shape[0]):
        out[k] = _clamp(p[k])


@njit(cache=True, nogil=True, error_model="numpy")
def motors_into(prev: FloatArray, cmd: FloatArray, curve: FloatArray, out: FloatArray) -> None:  # pragma: no cover
    """(N, 2) motor outputs after a tick into ``out`` (:func:`iw_zenoh.core.motor.step_motors`)."""
    n = prev.shape[0]
    _rows(prev, n, 2), _rows(cmd, n, 2), _long(curve, n), _rows(out, n, 2)
    for i in range(prev.shape[0]):
        out[i, 0] = _motor(prev[i, 0], cmd[i, 0], curve[i])
        out[i, 1] = _motor(prev[i, 1], cmd[i, 1], curve[i])


@njit(cache=True, nogil=True, error_model="numpy")
def speeds_into(out: FloatArray, max_speed: FloatArray, speeds: FloatArray) -> None:  # pragma: no cover
    """(N, 2) wheel speeds into ``speeds`` (:func:`iw_zenoh.core.motor.wheel_speeds_mps`)."""
    n = out.shape[0]
    _rows(out, n, 2), _long(max_speed, n), _rows(speeds, n, 2)
    for i in range(out.shape[0]):
        scale = max_speed[i] / MAX_POWER
        speeds[i, 0], speeds[i, 1] = out[i, 0] * scale, out[i, 1] * scale


@njit(cache=True, nogil=True, error_model="numpy")
def arcs_into(
    pose: FloatArray, wheel: FloatArray, base: FloatArray, dt: float, nxt: FloatArray
) -> None:  # pragma: no cover
    """(N, 3) poses after ``dt`` into ``nxt`` (:func:`iw_zenoh.core.motor.integrate_pose`)."""
    n = pose.shape[0]
    _rows(pose, n, 3), _rows(wheel, n, 2), _long(base, n), _rows(nxt, n, 3)
    for i in range(pose.shape[0]):
        x, y, th = pose[i, 0], pose[i, 1], pose[i, 2]
        nxt[i, 0], nxt[i, 1], nxt[i, 2] = _arc(x, y, th, wheel[i, 0], wheel[i, 1], base[i], dt)


@njit(cache=True, nogil=True, error_model="numpy")
def drive_into(
    pose: FloatArray,
    prev: FloatArray,
    cmd: FloatArray,
    curve: FloatArray,
    max_speed: FloatArray,
    base: FloatArray,
    dt: float,
    noise: FloatArray,
    nxt: FloatArray,
    out: FloatArray,
) -> None:  # pragma: no cover
    """A native tick into ``nxt`` and ``out`` (:func:`iw_zenoh.core.motor.step_drive`; ``noise``
    with no rows: none)."""
    noisy = noise.shape[0] > 0
    n = pose.shape[0]
    _rows(pose, n, 3), _rows(prev, n, 2), _rows(cmd, n, 2), _rows(nxt, n, 3), _rows(out, n, 2)
    _long(curve, n), _long(max_speed, n), _long(base, n)
    if noisy:
        _rows(noise, n, 2)
    for i in range(pose.shape[0]):
        nl, nr = (noise[i, 0], noise[i, 1]) if noisy else (0.0, 0.0)
        _native(pose, prev, cmd, i, curve[i], max_speed[i], base[i], dt, noisy, nl, nr, nxt, out)


@njit(cache=True, nogil=True, error_model="numpy")
def ciber_into(
    pose: FloatArray, prev: FloatArray, cmd: FloatArray, gain: FloatArray, nxt: FloatArray, out: FloatArray
) -> None:  # pragma: no cover
    """A Ciber-Rato cycle into ``nxt`` and ``out`` (:func:`iw_zenoh.core.motor.step_drive_ciberrato`)."""
    n = pose.shape[0]
    _rows(pose, n, 3), _rows(prev, n, 2), _rows(cmd, n, 2), _rows(gain, n, 2), _rows(nxt, n, 3), _rows(out, n, 2)
    for i in range(pose.shape[0]):
        _ciber(pose, prev, cmd, i, gain[i, 0], gain[i, 1], nxt, out)


@njit(cache=True, nogil=True, error_model="numpy")
def propose_into(
    pose: FloatArray,
    prev: FloatArray,
    cmd: FloatArray,
    table: FloatArray,
    dt: float,
    ciberrato: bool,
    z: FloatArray,
    motors_noise_pct: float,
    reported: FloatArray,
    nxt: FloatArray,
    out: FloatArray,
    linear: FloatArray,
    rolled: FloatArray,
) -> None:  # pragma: no cover
    """The world's proposal for N robots (:func:`iw_zenoh.core.world.propose`), into ``nxt``
    (N, 3), ``out`` (N, 2), ``linear`` (N,) and ``rolled`` (N, 2).

    Native: motor filter, wheel speeds times ``1 + mean + std * z`` (the table's motion noise),
    arc; ``rolled`` is the noiseless speed times ``dt``. Ciber-Rato: gains ``1 + pct / 100 * z``.
    ``z`` with no rows means no noise; ``reported`` with no rows means no report, else a Real
    robot (the table's ``REAL`` column) goes to its finite row or stays at ``pose``.
    """
    noisy = z.shape[0] > 0
    n = pose.shape[0]
    _rows(pose, n, 3), _rows(prev, n, 2), _rows(cmd, n, 2), _rows(table, n, TABLE_COLUMNS)
    _rows(nxt, n, 3), _rows(out, n, 2), _long(linear, n), _rows(rolled, n, 2)
    if noisy:
        _rows(z, n, 2)
    if reported.shape[0] > 0:
        _rows(reported, n, 3)
    k = motors_noise_pct / 100.0
    for i in range(pose.shape[0]):
        if ciberrato:
            gl, gr = (1.0 + k * z[i, 0], 1.0 + k * z[i, 1]) if noisy else (1.0, 1.0)
            _ciber(pose, prev, cmd, i, gl, gr, nxt, out)
            rolled[i, 0], rolled[i, 1] = out[i, 0], out[i, 1]
        else:
            mean, std = table[i, MEAN], table[i, STD]
            nl, nr = (mean + std * z[i, 0], mean + std * z[i, 1]) if noisy else (0.0, 0.0)
            scale = _native(
                pose, prev, cmd, i, table[i, CURVE], table[i, MAX_SPEED], table[i, BASE], dt, noisy, nl, nr, nxt, out
            )
            rolled[i, 0], rolled[i, 1] = out[i, 0] * scale * dt, out[i, 1] * scale * dt
        linear[i] = 0.5 * (out[i, 0] + out[i, 1])
        if table[i, REAL] != 0.0 and reported.shape[0] > 0:
            r = reported[i]
            src = r if math.isfinite(r[0]) and math.isfinite(r[1]) and math.isfinite(r[2]) else pose[i]
            nxt[i, 0], nxt[i, 1], nxt[i, 2] = src[0], src[1], src[2]


@njit(cache=True, nogil=True, error_model="numpy")
def commit_into(
    pose: FloatArray,
    prev: FloatArray,
    prop_pose: FloatArray,
    prop_out: FloatArray,
    prop_rolled: FloatArray,
    hit: BoolArray,
    held: BoolArray,
    ciberrato: bool,
    nxt: FloatArray,
    out: FloatArray,
    rolled: FloatArray,
    collided: BoolArray,
) -> None:  # pragma: no cover
    """The world's commit for N robots (:func:`iw_zenoh.core.world.commit`), into ``nxt``,
    ``out``, ``rolled`` and ``collided``: a robot that hit keeps its pose (Ciber-Rato: its x and
    y, taking the new heading); a held one (``held`` with no rows: none) keeps its pose and motors,
    rolls 0 and reads no collision."""
    some_held = held.shape[0] > 0
    n = pose.shape[0]
    _rows(pose, n, 3), _rows(prev, n, 2), _rows(prop_pose, n, 3), _rows(prop_out, n, 2), _rows(prop_rolled, n, 2)
    _rows(nxt, n, 3), _rows(out, n, 2), _rows(rolled, n, 2), _long(hit, n), _long(collided, n)
    if some_held:
        _long(held, n)
    for i in range(pose.shape[0]):
        if some_held and held[i]:
            nxt[i, 0], nxt[i, 1], nxt[i, 2] = pose[i, 0], pose[i, 1], pose[i, 2]
            out[i, 0], out[i, 1] = prev[i, 0], prev[i, 1]
            rolled[i, 0], rolled[i, 1] = 0.0, 0.0
            collided[i] = False
            continue
        nxt[i, 0], nxt[i, 1], nxt[i, 2] = prop_pose[i, 0], prop_pose[i, 1], prop_pose[i, 2]
        if hit[i]:
            nxt[i, 0], nxt[i, 1] = pose[i, 0], pose[i, 1]
            if not ciberrato:
                nxt[i, 2] = pose[i, 2]
        out[i, 0], out[i, 1] = prop_out[i, 0], prop_out[i, 1]
        rolled[i, 0], rolled[i, 1] = prop_rolled[i, 0], prop_rolled[i, 1]
        collided[i] = hit[i]


def floats(a: npt.ArrayLike) -> FloatArray:
    """``a`` as the kernels take it: C-ordered float64, writable (numba types a read-only array
    apart, and would compile a kernel again for it), copied only when it is not already."""
    # the cheapest checks (a tick makes a dozen): builtin dtypes are singletons, and carray is
    # C-contiguous, aligned and writable in one flag
    if type(a) is np.ndarray and a.dtype is _F64 and a.flags.carray:
        return a
    return np.array(a, dtype=np.float64, order="C")


def bools(a: npt.ArrayLike) -> BoolArray:
    """``a`` as (N,) C-ordered writable bools (see :func:`floats`)."""
    if type(a) is np.ndarray and a.dtype is _BOOL and a.flags.carray:
        return a
    return np.array(a, dtype=np.bool_, order="C")


def warm_up() -> None:
    """Compiles the kernels now (or loads them from the cache), so the first tick is not slow."""
    from iw_zenoh.core.motor import (  # noqa: PLC0415 (motor imports this module on first use)
        clamp_power,
        integrate_pose,
        step_drive,
        step_drive_ciberrato,
        step_motors,
        wheel_speeds_mps,
    )

    pose, two, one = np.zeros((1, 3)), np.zeros((1, 2)), np.ones(1)
    clamp_power(two)
    step_motors(two, two, one)
    wheel_speeds_mps(two, one)
    integrate_pose(pose, two, one, 0.1)
    step_drive(pose, two, two, DriveParams(one, one, one), 0.1)
    step_drive_ciberrato(pose, two, two, two + 1.0)
    table = np.ones((1, TABLE_COLUMNS))
    for ciberrato in (False, True):
        propose_into(
            pose, two, two, table, 0.1, ciberrato, two, 0.0, pose, pose.copy(), two.copy(), one.copy(), two.copy()
        )
    flag = np.zeros(1, dtype=np.bool_)
    commit_into(pose, two, pose, two, two, flag, flag, False, pose.copy(), two.copy(), two.copy(), flag.copy())
