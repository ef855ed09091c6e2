from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from iw_zenoh.core.calibration import fit_motor, speeds_from_ticks
from iw_zenoh.core.motor import MAX_POWER, step_motors


def _log(
    max_speed: float, curve: float, *, dt: float = 0.02, seconds: float = 6.0, noise: float = 0.0, seed: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """A synthetic step response of a chair whose motors follow the model, logged every dt."""
    t = np.arange(0.0, seconds, dt)
    g = np.random.default_rng(seed)
    return t, max_speed * (1.0 - curve ** (t / 0.1)) + g.normal(0, noise, len(t))


def test_the_fit_matches_the_discrete_motor_at_tick_instants() -> None:
    out = np.zeros((1, 2))
    v = []
    for _ in range(40):
        out = step_motors(out, np.full((1, 2), MAX_POWER), np.array([0.83]))
        v.append(out[0, 0] / MAX_POWER * 0.49)
    t = (np.arange(40) + 1) * 0.1
    fit = fit_motor(np.concatenate([[0.0], t]), np.concatenate([[0.0], v]))
    assert fit.curve == pytest.approx(0.83, rel=0.02)


@pytest.mark.parametrize(("speed", "curve"), [(0.49, 0.83), (0.5, 0.2), (0.8, 0.6)])
def test_calibration_recovers_known_parameters_within_5_percent(speed: float, curve: float) -> None:
    t, v = _log(speed, curve, noise=0.005)
    fit = fit_motor(t, v, period_s=0.1)
    assert fit.max_speed_mps == pytest.approx(speed, rel=0.05)
    assert fit.curve == pytest.approx(curve, rel=0.05)


def test_calibration_from_encoder_ticks_and_the_command(tmp_path: Path) -> None:
    t, v = _log(0.49, 0.83)
    dist = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    ticks = np.round(dist * 2000)
    assert fit_motor(t, speeds_from_ticks(t, ticks, ticks, 2000.0)).curve == pytest.approx(0.83, rel=0.05)
    log = tmp_path / "log.csv"
    log.write_text("t,left_ticks,right_ticks\n" + "".join(f"{a},{b},{b}\n" for a, b in zip(t, ticks, strict=True)))
    r = subprocess.run(
        [sys.executable, "-m", "iw_zenoh.cli", "calibrate", str(log)], capture_output=True, text=True, timeout=60
    )
    assert r.returncode == 0, r.stdout
    assert "AccelerationCurve = 0.8" in r.stdout
    assert "rise time 10-90 %: log" in r.stdout


def test_a_log_that_never_moves_is_refused() -> None:
    with pytest.raises(ValueError, match="never moved"):
        fit_motor(np.arange(20) * 0.1, np.zeros(20))
