"""The tick's pose arithmetic, compiled: body outlines placed at poses, the mounting points of
sensors, and the proximity cones' wedges (their edge normals and exact bounding boxes).

Why compiled (numba): on a learning environment's one chair, the numpy expressions these
replace (:func:`iw_zenoh.core.geometry.to_world`, the cones' wedge maths) were a dozen small
array calls each, and their fixed cost per call, not the arithmetic, was most of a step. Each
function here performs the numpy expression's operations in the same order on the same float64
values (the same ``cos``, ``sin`` and float remainder, no fused multiply-add: numba compiles
without fast-math), so its results are the numpy version's bit for bit
(``tests/core/test_placing.py`` checks them against it on random input). The collision check
(:func:`iw_zenoh.core.collision.check_collisions`) and the sensors
(:func:`iw_zenoh.core.sensors.read_sensors`) call them: every process and the in-process world
alike. Cached on disk as the other kernels (``cache=True``).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = ["mod_two_pi", "mounts", "outline_at", "swept_outlines", "wedges"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

PI = math.pi
TWO_PI = 2.0 * math.pi  # what numpy's ``2.0 * np.pi`` is
AXES = (0.0, math.pi, 0.5 * math.pi, -0.5 * math.pi)  # +x, -x, +y, -y (core.sensors' _AXES)


@njit(cache=True, nogil=True, inline="always")
def mod_two_pi(x: float) -> float:  # pragma: no cover
    """``x % (2 pi)`` (Python's float remainder, numba's: the divisor's sign, +0.0 for a zero)
    bit for bit, without the remainder's ``fmod`` in the usual case: an ``x`` in [0, 2 pi) is its
    own remainder (``x + 0.0``: -0.0 gives +0.0, as ``%`` does), one in [-2 pi, 0) is ``x + 2 pi``
    (what ``%`` adds to ``fmod``'s result, which is ``x`` itself there). In the laser's kernel the
    remainders were a fifth of its time."""
    if 0.0 <= x < TWO_PI:
        return x + 0.0
    if -TWO_PI <= x < 0.0:
        return x + TWO_PI
    return x % TWO_PI


@njit(cache=True, nogil=True, inline="always")
def _wrap(a: float) -> float:  # pragma: no cover
    """``(a + pi) % (2 pi) - pi``, as :func:`~iw_zenoh.core.geometry.wrap_rad` (numba's float
    remainder is Python's, which is numpy's: the divisor's sign)."""
    return mod_two_pi(a + PI) - PI


@njit(cache=True, nogil=True)
def _place(
    local: FloatArray, x: float, y: float, c: float, s: float, out: FloatArray, i: int
) -> None:  # pragma: no cover
    for k in range(local.shape[1]):
        lx = local[i, k, 0]
        ly = local[i, k, 1]
        out[i, k, 0] = x + c * lx - s * ly
        out[i, k, 1] = y + s * lx + c * ly


@njit(cache=True, nogil=True)
def outline_at(local: FloatArray, pose: FloatArray) -> FloatArray:  # pragma: no cover
    """(N, K, 2) outlines ``local`` (each in its robot's frame) placed at poses (N, 3): what
    ``to_world(local, pose[:, 0], pose[:, 1], pose[:, 2])`` gives."""
    out = np.empty(local.shape)
    for i in range(local.shape[0]):
        h = pose[i, 2]
        _place(local, pose[i, 0], pose[i, 1], math.cos(h), math.sin(h), out, i)
    return out


@njit(cache=True, nogil=True)
def swept_outlines(
    local: FloatArray, now: FloatArray, nxt: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:  # pragma: no cover
    """The outlines at the current poses, half-way (``interpolate_pose(now, nxt, 0.5)``: turning
    the short way) and at the next poses, as the collision check takes them."""
    n = local.shape[0]
    c_now, c_mid, c_next = np.empty(local.shape), np.empty(local.shape), np.empty(local.shape)
    for i in range(n):
        h0, h1 = now[i, 2], nxt[i, 2]
        _place(local, now[i, 0], now[i, 1], math.cos(h0), math.sin(h0), c_now, i)
        mx = now[i, 0] + 0.5 * (nxt[i, 0] - now[i, 0])
        my = now[i, 1] + 0.5 * (nxt[i, 1] - now[i, 1])
        mh = _wrap(h0 + 0.5 * _wrap(h1 - h0))
        _place(local, mx, my, math.cos(mh), math.sin(mh), c_mid, i)
        _place(local, nxt[i, 0], nxt[i, 1], math.cos(h1), math.sin(h1), c_next, i)
    return c_now, c_mid, c_next


@njit(cache=True, nogil=True)
def mounts(
    pose: FloatArray, owner: IntArray, xy: FloatArray, rows: IntArray
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover
    """World positions of sensors ``rows`` mounted at ``xy[rows]`` (robot frame) on robots
    ``owner`` (one a row): ``pose[owner, 0] + c * x - s * y`` and ``pose[owner, 1] + s * x + c * y``."""
    m = rows.shape[0]
    ox, oy = np.empty(m), np.empty(m)
    for t in range(m):
        r, i = rows[t], owner[t]
        h = pose[i, 2]
        c, s = math.cos(h), math.sin(h)
        lx, ly = xy[r, 0], xy[r, 1]
        ox[t] = pose[i, 0] + c * lx - s * ly
        oy[t] = pose[i, 1] + s * lx + c * ly
    return ox, oy


@njit(cache=True, nogil=True)
def wedges(
    pose: FloatArray,
    owner: IntArray,
    rows: IntArray,
    xy: FloatArray,
    angle: FloatArray,
    half_cone: FloatArray,
    range_m: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:  # pragma: no cover
    """The proximity cones ``rows`` (on robots ``owner``, one a row) at poses (N, 3): apexes
    ``ox``, ``oy``; (M, 4) inward normals ``(lx, ly, rx, ry)`` of each wedge's left and right
    edges; and (M, 2) lower and upper corners of each sector's exact bounding box (apex, both
    edge ends, and the arc's extremes along +-x and +-y where the arc passes them)."""
    m = rows.shape[0]
    ox, oy = mounts(pose, owner, xy, rows)
    nrm, lo, hi = np.empty((m, 4)), np.empty((m, 2)), np.empty((m, 2))
    for t in range(m):
        r = rows[t]
        phi = pose[owner[t], 2] + angle[r]
        half, rng = half_cone[r], range_m[r]
        left, right = phi + half, phi - half
        nrm[t, 0] = math.sin(left)
        nrm[t, 1] = -math.cos(left)
        nrm[t, 2] = -math.sin(right)
        nrm[t, 3] = math.cos(right)
        px, py = ox[t], oy[t]
        xl, xr = px + rng * -nrm[t, 1], px + rng * nrm[t, 3]
        yl, yr = py + rng * nrm[t, 0], py + rng * -nrm[t, 2]
        lo[t, 0], hi[t, 0] = min(px, min(xl, xr)), max(px, max(xl, xr))
        lo[t, 1], hi[t, 1] = min(py, min(yl, yr)), max(py, max(yl, yr))
        if abs(mod_two_pi(AXES[0] - phi + PI) - PI) <= half:
            hi[t, 0] = px + rng
        if abs(mod_two_pi(AXES[1] - phi + PI) - PI) <= half:
            lo[t, 0] = px - rng
        if abs(mod_two_pi(AXES[2] - phi + PI) - PI) <= half:
            hi[t, 1] = py + rng
        if abs(mod_two_pi(AXES[3] - phi + PI) - PI) <= half:
            lo[t, 1] = py - rng
    return ox, oy, nrm, lo, hi


def warm_up() -> None:
    """Compiles the functions now (or loads them from the cache)."""
    pose = np.zeros((1, 3))
    one = np.zeros(1, dtype=np.int64)
    local = np.zeros((1, 4, 2))
    outline_at(local, pose)
    swept_outlines(local, pose, pose)
    wedges(pose, one, one, np.zeros((1, 2)), np.zeros(1), np.ones(1), np.ones(1))
