"""The emulated chair board: watchdog, e-stop latch, encoders and ranges (pure, no line)."""

from __future__ import annotations

import pytest
from iw_zenoh.bridges.serial.board import WATCHDOG_S, Board, chair_spec
from iw_zenoh.bridges.serial.protocol import (
    FLAG_ESTOP,
    FLAG_ESTOP_BOARD,
    FLAG_WATCHDOG,
    NO_RANGE,
    Clear,
    EStop,
    Frame,
    Motors,
)

from iw_zenoh.core.lab import Lab, Wall
from iw_zenoh.errors import ConfigError


@pytest.fixture
def board() -> Board:
    return Board(chair_spec("c", start=(2.0, 2.0, 0.0)), Lab(width_m=10.0, height_m=5.0), seed=3)


def test_motors_drive_the_wheels_and_the_encoders_count(board: Board) -> None:
    for i in range(10):
        board.on_frame(Frame(i + 1, Motors(1000, 1000)), 0.05 * i)
        st = board.step(0.05 * i)
    assert st.wheels == (1000, 1000)
    assert st.ack == 10
    assert st.encoders[0] > 100
    assert board.true_pose()[0] > 2.05


def test_the_watchdog_zeroes_the_wheels_after_200_ms_without_a_frame(board: Board) -> None:
    board.on_frame(Frame(1, Motors(1000, 1000)), 0.0)
    assert board.wheels(WATCHDOG_S - 0.01) == (1000, 1000)
    assert board.wheels(WATCHDOG_S + 0.01) == (0, 0)
    assert board.step(WATCHDOG_S + 0.01).flags & FLAG_WATCHDOG


def test_estop_latches_until_clear_and_then_waits_for_a_fresh_command(board: Board) -> None:
    board.on_frame(Frame(1, EStop()), 0.0)
    board.on_frame(Frame(2, Motors(800, 800)), 0.05)
    assert board.wheels(0.05) == (0, 0)
    assert board.status(0.05).flags & FLAG_ESTOP
    board.on_frame(Frame(3, Clear()), 0.1)
    assert board.wheels(0.1) == (0, 0)
    board.on_frame(Frame(4, Motors(800, 800)), 0.15)
    assert board.wheels(0.15) == (800, 800)


def test_the_chairs_own_estop_latches_too(board: Board) -> None:
    board.on_frame(Frame(1, Motors(800, 800)), 0.0)
    board.press_estop()
    board.on_frame(Frame(2, Motors(800, 800)), 0.05)
    assert board.wheels(0.05) == (0, 0)
    assert board.status(0.05).flags & FLAG_ESTOP_BOARD


def test_ranges_see_the_real_room_in_millimetres() -> None:
    box = Wall(((3.5, 1.5), (4.0, 1.5), (4.0, 2.5), (3.5, 2.5)), 1.0)
    b = Board(chair_spec("c", start=(2.0, 2.0, 0.0)), Lab(width_m=10.0, height_m=5.0).with_walls((box,)), seed=1)
    ranges = b.step(0.0).ranges_mm
    near = [r for r in ranges if r != NO_RANGE]
    assert near
    assert min(near) < 1500


def test_chair_spec_reads_a_toml_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    f = tmp_path / "chair.toml"
    f.write_text("[chair]\nmax_speed_mps = 0.4\nticks_per_m = 1000\n")
    spec = chair_spec("c", path=str(f))
    assert spec.max_speed_mps == 0.4
    assert spec.encoder.ticks_per_m == 1000
    f.write_text("[chair]\nwheels = 3\n")
    with pytest.raises(ConfigError, match="wheels"):
        chair_spec("c", path=str(f))
