"""The readings' noise, compiled: proximity (metres and the Ciber-Rato value), laser ranges,
compass, GPS and wheel encoders, each from its true value and its standard normals.

Why compiled (numba): on a learning environment's one chair, these few values cost about forty
small numpy calls a tick, more than computing the distances. Each function performs the numpy
expression's operations (:func:`iw_zenoh.core.sensors.legacy_ir_value`,
the encoders' ``acc + rolled * (1 + slip) * ticks_per_m``, the laser's ``true + mean + std * z``
kept from below 0, and the rest of :func:`iw_zenoh.core.sensors.read_sensors`) in the same order
on the same float64 values, so the readings are the same bit for bit (``tests/core/test_readout.py``
checks them against the numpy expressions on random input). :func:`~iw_zenoh.core.sensors.read_sensors` calls them:
the sensors role and the in-process world alike. Cached on disk as the other kernels.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

__all__ = ["encoders", "noisy_proximity", "noisy_ranges", "pose_readings", "warm_up"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

LEGACY_NOTHING = 100.0  # Ciber-Rato's IR reading when nothing is seen (or closer than 0.01)
LEGACY_MIN_DIST = 0.01  # below this Ciber-Rato reads 100, as if nothing were there
DEG_PER_RAD = 180.0 / math.pi  # what np.degrees multiplies by


@njit(cache=True, nogil=True, inline="always")
def _at_least_zero(v: float) -> float:  # pragma: no cover
    """``np.maximum(v, 0.0)``: 0.0 for -0.0 too, NaN kept."""
    return v if v > 0.0 or v != v else 0.0


@njit(cache=True, nogil=True, inline="always")
def _wrap_deg(a: float) -> float:  # pragma: no cover
    """``(a + 180) % 360 - 180`` (core.geometry's wrap_deg: the float remainder takes the
    divisor's sign in numba as in numpy)."""
    return (a + 180.0) % 360.0 - 180.0


@njit(cache=True, nogil=True)
def noisy_proximity(
    true_d: FloatArray,
    legacy_d: FloatArray,
    z: FloatArray,
    owner: IntArray,
    mean_m: FloatArray,
    std_m: FloatArray,
    std_legacy: FloatArray,
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover
    """(M,) noisy proximity readings, metres (never negative, ``inf`` for nothing), and the
    legacy value ``floor(10 * (1/d + std * z) + 0.5) / 10`` (100 for nothing or closer than
    0.01), both from each sensor's normal ``z``; the noise terms are the owner robots'."""
    m = true_d.shape[0]
    prox, legacy = np.empty(m), np.empty(m)
    for k in range(m):
        i = owner[k]
        d = true_d[k]
        prox[k] = _at_least_zero(d + mean_m[i] + std_m[i] * z[k]) if math.isfinite(d) else math.inf
        e = legacy_d[k]
        ideal = 1.0 / e if math.isfinite(e) and e > LEGACY_MIN_DIST else LEGACY_NOTHING
        legacy[k] = math.floor(10.0 * (ideal + std_legacy[i] * z[k]) + 0.5) / 10.0
    return prox, legacy


@njit(cache=True, nogil=True)
def noisy_ranges(
    true_m: FloatArray, z: FloatArray, owner: IntArray, mean: FloatArray, std: FloatArray
) -> FloatArray:  # pragma: no cover
    """(L,) laser ranges ``true + mean + std * z`` (the beam's robot's noise), never negative,
    ``inf`` kept."""
    out = np.empty(true_m.shape[0])
    for k in range(true_m.shape[0]):
        t = true_m[k]
        i = owner[k]
        out[k] = _at_least_zero(t + mean[i] + std[i] * z[k]) if math.isfinite(t) else math.inf
    return out


@njit(cache=True, nogil=True)
def pose_readings(
    pose: FloatArray,
    z_compass: FloatArray,
    z_gps: FloatArray,
    offset: tuple[float, float],
    compass: tuple[FloatArray, FloatArray],
    gps_m: tuple[FloatArray, FloatArray],
    gps_heading: tuple[FloatArray, FloatArray],
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover
    """(N,) compass headings (deg, wrapped) and (N, 3) GPS (x, y shifted by ``offset``, and
    heading in degrees), each noise term a ``(mean, std)`` pair of (N,) arrays."""
    n = pose.shape[0]
    comp, gps = np.empty(n), np.empty((n, 3))
    for i in range(n):
        deg = pose[i, 2] * DEG_PER_RAD
        comp[i] = _wrap_deg(deg + compass[0][i] + compass[1][i] * z_compass[i])
        gps[i, 0] = pose[i, 0] + offset[0] + gps_m[0][i] + gps_m[1][i] * z_gps[i, 0]
        gps[i, 1] = pose[i, 1] + offset[1] + gps_m[0][i] + gps_m[1][i] * z_gps[i, 1]
        gps[i, 2] = _wrap_deg(deg + gps_heading[0][i] + gps_heading[1][i] * z_gps[i, 2])
    return comp, gps


@njit(cache=True, nogil=True)
def encoders(
    acc: FloatArray, rolled_m: FloatArray, ticks_per_m: FloatArray, z: FloatArray, mean: FloatArray, std: FloatArray
) -> FloatArray:  # pragma: no cover
    """(N, 2) encoder ticks after this tick: ``acc + rolled * (1 + slip) * ticks_per_m`` with
    ``slip = mean + std * z`` (the encoders' count)."""
    out = np.empty(acc.shape)
    for i in range(acc.shape[0]):
        for w in range(2):
            slip = mean[i] + std[i] * z[i, w]
            out[i, w] = acc[i, w] + rolled_m[i, w] * (1.0 + slip) * ticks_per_m[i]
    return out


def warm_up() -> None:
    """Compiles the functions now (or loads them from the cache)."""
    one, i1, p = np.zeros(1), np.zeros(1, dtype=np.int64), np.zeros((1, 3))
    noisy_proximity(one, one, one, i1, one, one, one)
    noisy_ranges(one, one, i1, one, one)
    pose_readings(p, one, p, (0.0, 0.0), (one, one), (one, one), (one, one))
    encoders(np.zeros((1, 2)), np.zeros((1, 2)), one, np.zeros((1, 2)), one, one)
