"""The chair emulator on a real pseudo-terminal: its own watchdog, and corrupt bytes that never move it."""

from __future__ import annotations

import io
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from iw_zenoh.bridges.serial.board import WATCHDOG_S, Board, chair_spec
from iw_zenoh.bridges.serial.emulator import Emulator, Faults
from iw_zenoh.bridges.serial.line import PtyLine, SerialLine
from iw_zenoh.bridges.serial.protocol import FrameDecoder, Motors, Status, encode_frame

from iw_zenoh.core.lab import Lab

SLACK_S = 0.3  # scheduling on a busy 2-core machine (the suite runs two workers): the 200 ms rule itself is test_serial_board's, on a fake clock
WAIT_S = 10.0  # the longest a status the test waits for may take on a loaded machine


@pytest.fixture
def emulator(tmp_path: Path) -> Iterator[tuple[Emulator, str, io.StringIO]]:
    link = str(tmp_path / "chair")
    log = io.StringIO()
    board = Board(chair_spec("c", start=(2.0, 2.0, 0.0)), Lab(width_m=10.0, height_m=5.0), seed=1)
    emu = Emulator(board, lambda: PtyLine(link), faults=Faults(), wheels_log=log)
    emu._plug(True)  # the pty exists before the test opens it
    t = threading.Thread(target=emu.run, daemon=True)
    t.start()
    yield emu, link, log
    emu.stop.set()
    t.join(5)


def _statuses(line: SerialLine, dec: FrameDecoder, until_s: float) -> Iterator[Status]:
    while time.monotonic() < until_s:
        for f in dec.feed(line.read(0.05)):
            if isinstance(f.msg, Status):
                yield f.msg


def test_a_silent_computer_stops_the_wheels_within_200_ms(emulator: tuple[Emulator, str, io.StringIO]) -> None:
    emu, link, log = emulator
    line = SerialLine(link)
    dec = FrameDecoder()
    for seq in range(10):  # a computer commanding at 20 Hz, then silent
        line.write(encode_frame(Motors(900, 900), seq))
        last_ns = time.monotonic_ns()
        list(_statuses(line, dec, time.monotonic() + 0.05))
    # the stop after the last frame (a status of a stall in between may still be queued), waited
    # for well past the watchdog: its 200 ms are measured on the wheels log below
    stopped = next(s for s in _statuses(line, dec, time.monotonic() + WAIT_S) if s.wheels == (0, 0) and s.ack == 9)
    assert stopped.ack == 9
    changes = [tuple(int(v) for v in ln.split()) for ln in log.getvalue().splitlines()]
    assert changes[0][1:] == (900, 900)
    zero_ns = [t for t, lw, rw in changes if (lw, rw) == (0, 0)][-1]  # the stop after the last frame
    assert (zero_ns - last_ns) / 1e9 <= WATCHDOG_S + SLACK_S
    line.close()


def test_corrupted_frames_are_dropped_and_never_move_the_chair(emulator: tuple[Emulator, str, io.StringIO]) -> None:
    emu, link, log = emulator
    line = SerialLine(link)
    dec = FrameDecoder()
    for seq in range(20):
        frame = bytearray(encode_frame(Motors(1500, 1500), seq))
        frame[seq % (len(frame) - 1)] ^= 1 << (seq % 8)
        line.write(bytes(frame))
    seen = list(_statuses(line, dec, time.monotonic() + 0.5))
    deadline = time.monotonic() + WAIT_S
    while emu.decoder.stats.dropped_total < 1 and time.monotonic() < deadline:  # the board read them late
        seen += _statuses(line, dec, time.monotonic() + 0.1)
    assert seen
    assert all(s.wheels == (0, 0) for s in seen)
    assert log.getvalue() == ""
    assert emu.decoder.stats.dropped_total >= 1
    assert emu.decoder.stats.frames == 0
    line.close()
