"""``iwz chair emulate [--pty | --port DEV]``: a chair board on a real serial line.

The board (:class:`~iw_zenoh.bridges.serial.board.Board`) runs in real time behind a
pseudo-terminal it creates (its path is printed: ``chair board on /dev/pts/N``) or a device. It
answers every valid frame and sends a Status frame every board cycle (50 ms).

Faults on demand, for tests: ``--fault drop|flip`` loses or corrupts bytes both ways (rate
``--fault-rate``), ``stall`` freezes the link (nothing read, nothing sent; the board's watchdog
stops the chair), ``unplug`` closes the pty and makes a new one (keep a stable path with
``--link``). A fault is active from ``--fault-at`` for ``--fault-for`` seconds, or toggled by
SIGUSR1. ``--wheels-log`` appends ``monotonic_ns left right`` each time the wheels' powers change.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TextIO

import numpy as np

from iw_zenoh.agent.places import parse_boxes
from iw_zenoh.core.lab import Lab
from iw_zenoh.errors import IwError
from iw_zenoh.maps import load_lab
from iw_zenoh.process.runtime import install_stop_signals, setup_logging, watch_supervisor

from .board import WATCHDOG_S, Board, chair_spec
from .line import Line, LinkLost, PtyLine, SerialLine
from .protocol import FrameDecoder, encode_frame

__all__ = ["Emulator", "Faults", "main"]

logger = logging.getLogger(__name__)


@dataclass
class Faults:
    """Faults injected on the line (drop, flip, stall, unplug), active in a window or by toggle."""

    kind: str = ""
    rate: float = 0.05
    at_s: float = float("inf")
    for_s: float = 0.0
    toggled: bool = False
    seed: int = 0

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)

    def active(self, since_start_s: float) -> bool:
        """Whether the fault is on now."""
        return bool(self.kind) and (self.toggled or self.at_s <= since_start_s < self.at_s + self.for_s)

    def mangle(self, data: bytes, on: bool) -> bytes:
        """The bytes after dropping or flipping some."""
        if not on or not data or self.kind not in ("drop", "flip"):
            return data
        hit = self.rng.random(len(data)) < self.rate
        arr = np.frombuffer(data, dtype=np.uint8).copy()
        if self.kind == "drop":
            return arr[~hit].tobytes()
        arr[hit] ^= (1 << self.rng.integers(0, 8, int(hit.sum()))).astype(np.uint8)
        return arr.tobytes()


class Emulator:
    """The board behind a line, in real time.

    Args:
        board: The board model.
        open_line: Opens the line (again after an unplug).
        faults: What to inject.
        period_s: Board cycle.
        wheels_log: Where wheel power changes are appended, or None.
    """

    def __init__(
        self,
        board: Board,
        open_line: Callable[[], Line],
        *,
        faults: Faults,
        period_s: float = 0.05,
        wheels_log: TextIO | None = None,
    ) -> None:
        self.board = board
        self.open_line = open_line
        self.line: Line | None = None
        self.faults = faults
        self.period_s = period_s
        self.wheels_log = wheels_log
        self.decoder = FrameDecoder()
        self.seq = 0
        self.stop = threading.Event()
        self._wheels = (0, 0)
        self._touching = False
        self._t0 = time.monotonic()

    def _log_wheels(self, now: float) -> None:
        w = self.board.wheels(now)
        if w != self._wheels:
            self._wheels = w
            if self.wheels_log is not None:
                self.wheels_log.write(f"{time.monotonic_ns()} {w[0]} {w[1]}\n")
                self.wheels_log.flush()

    def _plug(self, want: bool) -> None:
        if want and self.line is None:
            self.line = self.open_line()
            self.decoder.resync()
            print(f"chair board on {getattr(self.line, 'link', '') or getattr(self.line, 'path', '')}", flush=True)
        elif not want and self.line is not None:
            self.line.close()
            self.line = None
            logger.warning("unplugged")

    def cycle(self, next_step: float) -> float:
        """Reads until the next board step or watchdog deadline, acts; returns the next step time."""
        now = time.monotonic()
        on = self.faults.active(now - self._t0)
        stalled = on and self.faults.kind in ("stall", "unplug")
        self._plug(not (on and self.faults.kind == "unplug"))
        deadline = min(next_step, self.board.last_valid_s + WATCHDOG_S)
        wait = max(0.0, deadline - now) if deadline > now else max(0.0, next_step - now)
        data = b""
        if self.line is not None and not stalled:
            try:
                data = self.line.read(wait)
            except LinkLost as e:
                logger.warning("line lost: %s", e)
        else:
            self.stop.wait(min(wait, 0.01))
        now = time.monotonic()
        for frame in self.decoder.feed(self.faults.mangle(data, on)):
            self.board.on_frame(frame, now)
        self._log_wheels(now)
        if now < next_step:
            return next_step
        status = self.board.step(now)
        if status.bumpers and not self._touching:
            logger.warning("the real chair touched something at %s (true pose)", self.board.true_pose())
        self._touching = bool(status.bumpers)
        if self.board.watchdog(now):
            self.decoder.resync()  # a bridge that restarted counts from 0 again
        if self.line is not None and not stalled:
            self.line.write(self.faults.mangle(encode_frame(status, self.seq), on))
            self.seq += 1
        return next_step + self.period_s if now - next_step < self.period_s else now + self.period_s

    def run(self) -> None:
        """Runs until stopped."""
        next_step = time.monotonic()
        try:
            while not self.stop.is_set():
                next_step = self.cycle(next_step)
        finally:
            if self.line is not None:
                self.line.close()


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="iwz chair emulate", description=(__doc__ or "").strip().splitlines()[0])
    where = p.add_mutually_exclusive_group()
    where.add_argument("--pty", action="store_true", help="make a pseudo-terminal and print its path (default)")
    where.add_argument("--port", default="", help="a serial device or pyserial URL to be the board on")
    p.add_argument("--link", default="", help="--pty: also a symlink at this path to the pty (same across unplugs)")
    p.add_argument("--baud", type=int, default=115200, help="--port: bits a second (default 115200)")
    p.add_argument("--map", default="", help="the real room (Lab XML); default an empty 30 x 15 m room")
    p.add_argument("--room", default="", help="real obstacles the simulator may not know: x0,y0,x1,y1;...")
    p.add_argument("--start", default="1,1,0", help="where the chair really starts: x,y,dir_deg")
    p.add_argument(
        "--spec", default="", help="a spec file: its [chair] table sets any registration field (docs/spec.md)"
    )
    p.add_argument("--seed", type=int, default=0, help="noise seed")
    p.add_argument("--period-ms", type=float, default=50.0, help="board cycle (default 50 ms)")
    p.add_argument("--fault", choices=["drop", "flip", "stall", "unplug"], default="", help="inject a fault")
    p.add_argument("--fault-rate", type=float, default=0.05, help="drop/flip: chance per byte (default 0.05)")
    p.add_argument("--fault-at", type=float, default=float("inf"), help="the fault starts this many s in")
    p.add_argument("--fault-for", type=float, default=0.0, help="and lasts this long (SIGUSR1 also toggles it)")
    p.add_argument("--wheels-log", default="", help="append 'monotonic_ns left right' on each wheel change")
    p.add_argument("-v", "--verbose", action="count", default=0)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz chair emulate``."""
    args = list(sys.argv[1:] if argv is None else argv)
    if args and args[0] == "emulate":
        args = args[1:]
    elif not args or args[0] not in ("-h", "--help"):
        print("usage: iwz chair emulate [--pty | --port DEV] [options]   (iwz chair emulate --help)")
        return 2
    a = _parser().parse_args(args)
    setup_logging(a.verbose, "chair")
    try:
        x, y, d = (float(v) for v in a.start.split(","))
        room = load_lab(a.map) if a.map else None
        lab = (room or Lab(width_m=30.0, height_m=15.0)).with_walls(parse_boxes(a.room))
        board = Board(chair_spec("chair", path=a.spec, start=(x, y, d)), lab, seed=a.seed, dt_s=a.period_ms / 1000)
    except (IwError, ValueError, OSError) as e:
        print(f"iwz chair emulate: {e}")
        return 2
    faults = Faults(a.fault, a.fault_rate, a.fault_at, a.fault_for, seed=a.seed)

    def opener() -> Line:
        return SerialLine(a.port, a.baud) if a.port else PtyLine(a.link)

    log = open(a.wheels_log, "a") if a.wheels_log else None  # noqa: SIM115 (kept for the whole run)
    emu = Emulator(board, opener, faults=faults, period_s=a.period_ms / 1000, wheels_log=log)
    install_stop_signals(emu.stop)
    watch_supervisor()  # started by iwz run (a [chair] without a port): stops, its pty link gone, if it is killed
    signal.signal(signal.SIGUSR1, lambda *_: setattr(faults, "toggled", not faults.toggled))
    try:
        emu.run()
    except LinkLost as e:
        print(f"iwz chair emulate: {e}")
        return 1
    finally:
        if log is not None:
            log.close()
    return 0
