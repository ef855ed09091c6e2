"""A serial bridge's own log of a run, as iwz calibrate reads it."""

from __future__ import annotations

from pathlib import Path

from iw_zenoh.bridges.serial.board import Board, chair_spec
from iw_zenoh.bridges.serial.node import CSV_HEADER
from iw_zenoh.bridges.serial.protocol import Frame, Motors, power_to_units

from iw_zenoh.core.lab import Lab


def bridge_log(path: Path, spec: Path) -> None:
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
