"""The compiled noise of the readings (:mod:`iw_zenoh.core.readout`) gives the numpy expressions
it replaced in ``core.sensors`` bit for bit, on random true values (``inf`` for nothing in range,
0 for a sensor inside something, below Ciber-Rato's 0.01), normals and noise terms; the numpy
versions are kept here, as they were, as the reference."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from iw_zenoh.core import readout
from iw_zenoh.core.geometry import wrap_deg
from iw_zenoh.core.sensors import legacy_ir_value

FINITE = st.floats(-1e3, 1e3, allow_nan=False, width=64)
DISTANCE = st.one_of(st.floats(0.0, 50.0, width=64), st.sampled_from([np.inf, 0.0, 0.01, 0.005, 1e-300]))
NOISE = st.one_of(st.just(0.0), st.floats(-0.5, 0.5, width=64))


def _same(a: np.ndarray, b: np.ndarray) -> None:
    assert a.shape == b.shape
    assert a.dtype == b.dtype
    assert np.array_equal(a, b, equal_nan=True), np.argwhere(a != b)[:5]
    assert np.array_equal(np.signbit(a), np.signbit(b))  # -0.0 and 0.0 told apart too


@st.composite
def sensors(draw: st.DrawFn) -> tuple[np.ndarray, ...]:
    n = draw(st.integers(1, 4))
    m = draw(st.integers(0, 20))
    owner = np.sort(draw(arrays(np.int64, (m,), elements=st.integers(0, n - 1))))
    true_d = draw(arrays(np.float64, (m,), elements=DISTANCE))
    legacy_d = draw(st.one_of(st.just(true_d), arrays(np.float64, (m,), elements=DISTANCE)))
    z = draw(arrays(np.float64, (m,), elements=st.floats(-6.0, 6.0, width=64)))
    mean, std, std_l = (draw(arrays(np.float64, (n,), elements=NOISE)) for _ in range(3))
    return true_d, legacy_d, z, owner, mean, std, np.abs(std_l)


@given(sensors())
@settings(max_examples=100, deadline=None)
def test_proximity_and_laser_noise_are_the_numpy_ones(case: tuple[np.ndarray, ...]) -> None:
    true_d, legacy_d, z, own, mean, std, std_l = case
    # core.sensors' _proximity_readings, as it was
    prox = true_d + mean[own] + std[own] * z
    prox = np.where(np.isfinite(true_d), np.maximum(prox, 0.0), np.inf)
    legacy = legacy_ir_value(legacy_d, z, std_l[own])
    got_prox, got_legacy = readout.noisy_proximity(true_d, legacy_d, z, own, mean, std, std_l)
    _same(got_prox, prox)
    _same(got_legacy, legacy)

    # core.laser's noisy_ranges, as it was
    ranges = np.where(np.isfinite(true_d), np.maximum(true_d + mean[own] + std[own] * z, 0.0), np.inf)
    _same(readout.noisy_ranges(true_d, z, own, mean, std), ranges)


@st.composite
def robots(draw: st.DrawFn) -> tuple[np.ndarray, ...]:
    n = draw(st.integers(0, 5))
    pose = draw(arrays(np.float64, (n, 3), elements=FINITE))
    pose[:, 2] = draw(arrays(np.float64, (n,), elements=st.floats(-10.0, 10.0, width=64)))
    zs = [draw(arrays(np.float64, shape, elements=st.floats(-6.0, 6.0, width=64))) for shape in ((n,), (n, 3), (n, 2))]
    terms = [draw(arrays(np.float64, (n,), elements=NOISE)) for _ in range(8)]
    acc = draw(arrays(np.float64, (n, 2), elements=FINITE))
    rolled = draw(arrays(np.float64, (n, 2), elements=st.floats(-0.2, 0.2, width=64)))
    tpm = draw(arrays(np.float64, (n,), elements=st.floats(1.0, 5000.0, width=64)))
    return (pose, *zs, *terms, acc, rolled, tpm)


@given(robots(), st.tuples(FINITE, FINITE))
@settings(max_examples=100, deadline=None)
def test_compass_gps_and_encoders_are_the_numpy_ones(case: tuple[np.ndarray, ...], offset: tuple[float, float]) -> None:
    pose, z_c, z_g, z_e, cm, cs, gm, gs, hm, hs, sm, ss, acc, rolled, tpm = case
    # core.sensors' read_sensors and _gps, as they were
    heading_deg = np.degrees(pose[:, 2])
    compass = wrap_deg(heading_deg + cm + cs * z_c)
    gps = np.empty((len(pose), 3))
    gps[:, 0] = pose[:, 0] + offset[0] + gm + gs * z_g[:, 0]
    gps[:, 1] = pose[:, 1] + offset[1] + gm + gs * z_g[:, 1]
    gps[:, 2] = wrap_deg(heading_deg + hm + hs * z_g[:, 2])
    slip = sm[:, None] + ss[:, None] * z_e
    enc = np.asarray(acc + rolled * (1.0 + slip) * tpm[:, None], dtype=np.float64)  # core.sensors' step_encoders

    got_compass, got_gps = readout.pose_readings(pose, z_c, z_g, offset, (cm, cs), (gm, gs), (hm, hs))
    _same(got_compass, compass)
    _same(got_gps, gps)
    _same(readout.encoders(acc, rolled, tpm, z_e, sm, ss), enc)
