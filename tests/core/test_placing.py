"""The compiled pose arithmetic (:mod:`iw_zenoh.core.placing`) gives the numpy expressions it
replaced bit for bit, on random poses, outlines and sensor layouts: ``to_world``, the collision
check's half-way pose, the sensors' mounting points, and the cones' wedge normals and bounding
boxes (the numpy versions are kept here, as they were in ``core.sensors``, as the reference)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from iw_zenoh.core.cellgrid import _boxes
from iw_zenoh.core.collision import interpolate_pose
from iw_zenoh.core.geometry import to_world
from iw_zenoh.core.placing import mounts, outline_at, swept_outlines, wedges

COORD = st.floats(-1e4, 1e4, allow_nan=False, allow_infinity=False, width=64)
ANGLE = st.one_of(
    st.floats(-50.0, 50.0, allow_nan=False, width=64),
    st.sampled_from([0.0, -0.0, np.pi, -np.pi, 0.5 * np.pi, -0.5 * np.pi, 2 * np.pi, 1e-17, -1e-17]),
)


@st.composite
def poses(draw: st.DrawFn, n: int) -> np.ndarray:
    out = np.empty((n, 3))
    out[:, :2] = draw(arrays(np.float64, (n, 2), elements=COORD))
    out[:, 2] = draw(arrays(np.float64, (n,), elements=ANGLE))
    return out


@st.composite
def cases(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = draw(st.integers(0, 6))
    k = draw(st.sampled_from([4, 24]))
    local = draw(arrays(np.float64, (n, k, 2), elements=st.floats(-3.0, 3.0, allow_nan=False, width=64)))
    return local, draw(poses(n)), draw(poses(n))


# numba's cos and sin are the C library's; numpy's float64 ones are too on this kind of machine
# (x86-64-v3, checked on 2 million values), but numpy may take its own SIMD path on another
# (AVX-512) and differ in the last bit: there the reference is held to a few units of the last
# place, here to the bit. Lock-step and in-process runs agree either way: both call `placing`.
_PROBE = np.linspace(-60.0, 60.0, 200_001)
LIBM_TRIG = np.array_equal(np.sin(_PROBE), [math.sin(x) for x in _PROBE]) and np.array_equal(
    np.cos(_PROBE), [math.cos(x) for x in _PROBE]
)


def _same(a: np.ndarray, b: np.ndarray) -> None:
    """Equal bit for bit (signed zeros aside: -0.0 and 0.0 are one coordinate) where numpy's
    trigonometry is the C library's; else within a few units of the last place."""
    assert a.shape == b.shape
    if LIBM_TRIG:
        assert np.array_equal(a, b), np.argwhere(a != b)[:5]
    else:
        np.testing.assert_allclose(a, b, rtol=1e-14, atol=1e-12)


@given(cases())
@settings(max_examples=100, deadline=None)
def test_outlines_are_to_worlds_bit_for_bit(case: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    local, now, nxt = case
    _same(outline_at(local, now), to_world(local, now[:, 0], now[:, 1], now[:, 2]))
    mid = interpolate_pose(now, nxt, 0.5)
    c_now, c_mid, c_next = swept_outlines(local, now, nxt)
    _same(c_now, to_world(local, now[:, 0], now[:, 1], now[:, 2]))
    _same(c_mid, to_world(local, mid[:, 0], mid[:, 1], mid[:, 2]))
    _same(c_next, to_world(local, nxt[:, 0], nxt[:, 1], nxt[:, 2]))


def _wedge_normals(phi: np.ndarray, half: np.ndarray) -> np.ndarray:
    """core.sensors' numpy version, as it was."""
    out = np.empty((len(phi), 4))
    left, right = phi + half, phi - half
    out[:, 0] = np.sin(left)
    out[:, 1] = -np.cos(left)
    out[:, 2] = -np.sin(right)
    out[:, 3] = np.cos(right)
    return out


_AXES = np.array([[0.0], [np.pi], [0.5 * np.pi], [-0.5 * np.pi]])


def _wedge_bounds(
    ox: np.ndarray, oy: np.ndarray, phi: np.ndarray, half: np.ndarray, r: np.ndarray, normals: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """core.sensors' numpy version, as it was."""
    lxd, lyd = -normals[:, 1], normals[:, 0]
    rxd, ryd = normals[:, 3], -normals[:, 2]
    lo, hi = np.empty((len(ox), 2)), np.empty((len(ox), 2))
    xl, xr, yl, yr = ox + r * lxd, ox + r * rxd, oy + r * lyd, oy + r * ryd
    np.minimum(ox, np.minimum(xl, xr), out=lo[:, 0])
    np.maximum(ox, np.maximum(xl, xr), out=hi[:, 0])
    np.minimum(oy, np.minimum(yl, yr), out=lo[:, 1])
    np.maximum(oy, np.maximum(yl, yr), out=hi[:, 1])
    within = np.abs((_AXES - phi + np.pi) % (2.0 * np.pi) - np.pi) <= half
    np.copyto(hi[:, 0], ox + r, where=within[0])
    np.copyto(lo[:, 0], ox - r, where=within[1])
    np.copyto(hi[:, 1], oy + r, where=within[2])
    np.copyto(lo[:, 1], oy - r, where=within[3])
    return lo, hi


@st.composite
def layouts(draw: st.DrawFn) -> tuple[np.ndarray, ...]:
    n = draw(st.integers(1, 4))
    m = draw(st.integers(0, 12))
    pose = draw(poses(n))
    owner = np.sort(draw(arrays(np.int64, (m,), elements=st.integers(0, n - 1))))
    xy = draw(arrays(np.float64, (m, 2), elements=st.floats(-1.0, 1.0, allow_nan=False, width=64)))
    angle = draw(arrays(np.float64, (m,), elements=ANGLE))
    half = draw(arrays(np.float64, (m,), elements=st.one_of(st.floats(0.0, np.pi, width=64), st.just(np.pi / 6))))
    rng = draw(arrays(np.float64, (m,), elements=st.floats(0.0, 20.0, width=64)))
    rows = sorted(draw(st.sets(st.integers(0, m - 1), max_size=m))) if m else []
    return pose, owner, xy, angle, half, rng, np.asarray(rows, dtype=np.int64)


@given(layouts())
@settings(max_examples=100, deadline=None)
def test_wedges_are_the_numpy_wedges_bit_for_bit(layout: tuple[np.ndarray, ...]) -> None:
    pose, owner, xy, angle, half, rng, rows = layout
    own = owner[rows]
    # core.sensors' _proximity before: mounting points, directions, normals, boxes
    c, s = np.cos(pose[own, 2]), np.sin(pose[own, 2])
    ox = pose[own, 0] + c * xy[rows, 0] - s * xy[rows, 1]
    oy = pose[own, 1] + s * xy[rows, 0] + c * xy[rows, 1]
    phi = pose[own, 2] + angle[rows]
    normals = _wedge_normals(phi, half[rows])
    lo, hi = _wedge_bounds(ox, oy, phi, half[rows], rng[rows], normals)

    got = wedges(pose, own, rows, xy, angle, half, rng)
    for a, b in zip(got, (ox, oy, normals, lo, hi), strict=True):
        _same(a, b)
    mx, my = mounts(pose, own, xy, rows)
    _same(mx, ox)
    _same(my, oy)


@given(cases())
@settings(max_examples=100, deadline=None)
def test_outline_boxes_are_numpys_min_and_max(case: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    local, now, _ = case
    xy = outline_at(local, now)
    want = np.concatenate([xy.min(axis=1), xy.max(axis=1)], axis=1) if len(xy) else np.zeros((0, 4))
    _same(_boxes(xy), want)
