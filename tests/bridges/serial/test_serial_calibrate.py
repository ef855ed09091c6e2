"""iwz calibrate reads a serial bridge's own log of a run: it finds the step and fits the chair."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from iw_zenoh.core.calibration import step_window
from iw_zenoh.record.calibrate import main as calibrate
from tests.support.serial_logs import bridge_log as _bridge_log


def test_step_window_finds_the_step_to_top_power() -> None:
    cmd = np.array([0, 0, 0.15, 0.15, 0.15, 0.1, 0.0])
    assert step_window(cmd, cmd) == (1, 5)
    with pytest.raises(ValueError, match="never commands"):
        step_window(np.zeros(4), np.zeros(4))


def test_calibrate_fits_the_chair_from_the_bridges_log(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log, spec = tmp_path / "bridge.csv", tmp_path / "chair.toml"
    spec.write_text("[chair]\nacceleration_curve = 0.9\nmax_speed_mps = 0.49\n")  # the real chair's slow rise (7.2)
    _bridge_log(log, spec)
    assert calibrate([str(log), "--period-ms", "50"]) == 0
    out = capsys.readouterr().out
    speed = float(out.split("MaxSpeed = ")[1].split()[0])
    curve = float(out.split("AccelerationCurve = ")[1].split()[0])
    assert "step to power 0.15 at t = 10.95 s" in out
    assert speed == pytest.approx(0.49, rel=0.05)
    assert curve == pytest.approx(0.9, abs=0.03)  # per 50 ms board cycle
