"""iwz calibrate reads a serial bridge's own log of a run: it finds the step and fits the chair."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from iw_zenoh.bridges.serial.board import Board, chair_spec
from iw_zenoh.bridges.serial.node import CSV_HEADER
from iw_zenoh.bridges.serial.protocol import Frame, Motors, power_to_units

from iw_zenoh.core.calibration import step_window
from iw_zenoh.core.lab import Lab
from iw_zenoh.record.calibrate import main as calibrate


def _bridge_log(path: Path, spec: Path) -> None:
    """A run as the bridge logs it: at rest, a step to full power, then stopped again."""
    chair = chair_spec("c", path=str(spec), start=(2.0, 7.5, 0.0))
    board = Board(chair, Lab(width_m=30.0, height_m=15.0), seed=2)
    lines = [CSV_HEADER]
    for i in range(160):
        t = i * board.dt_s
        power = 0.15 if 20 <= i < 140 else 0.0
        board.on_frame(Frame(i, Motors(power_to_units(power), power_to_units(power))), t)
        st = board.step(t)
        lines.append(f"{10 + t:.4f},{st.encoders[0]},{st.encoders[1]},{power},{power},0,0,25.0,0\n")
    path.write_text("".join(lines))


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
