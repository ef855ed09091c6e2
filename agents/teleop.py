"""The terminal as the wheelchair's joystick: arrow keys, space, + and - and q read in cbreak
mode in a thread, turned into wheel powers that stop when no key has come for a while."""

from __future__ import annotations

import math
import os
import select
import signal
import sys
import termios
import threading
import time
import tty

from iw_zenoh.core.motor import MAX_POWER

__all__ = ["KeyReader", "Teleop", "terminal_teleop"]


class KeyReader:
    """Reads arrow keys, space, +, - and q from a terminal in cbreak mode, in a thread.

    Args:
        fd: The terminal's file descriptor (stdin).
    """

    KEYS = {b"\x1b[A": "up", b"\x1b[B": "down", b"\x1b[C": "right", b"\x1b[D": "left", b" ": "stop"}
    KEYS |= {b"+": "faster", b"=": "faster", b"-": "slower", b"q": "quit"}

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.last: str | None = None
        self.at = -math.inf
        self.quit = threading.Event()
        self.ready = threading.Event()  # set once the terminal is in cbreak mode
        self.lock = threading.Lock()
        self._pending: list[str] = []

    def feed(self, data: bytes) -> None:
        """Parses bytes from the terminal."""
        i = 0
        while i < len(data):
            for seq, name in self.KEYS.items():
                if data.startswith(seq, i):
                    with self.lock:
                        self.last, self.at = name, time.monotonic()
                        self._pending.append(name)
                    if name == "quit":
                        self.quit.set()
                    i += len(seq)
                    break
            else:
                i += 1  # an unknown byte: ignored

    def take(self) -> list[str]:
        """Keys pressed since the last call."""
        with self.lock:
            out, self._pending = self._pending, []
            return out

    def run(self) -> None:
        """Reads until quit (call in a thread)."""
        old = termios.tcgetattr(self.fd) if os.isatty(self.fd) else None
        try:
            if old is not None:
                tty.setcbreak(self.fd)
            self.ready.set()
            while not self.quit.is_set():
                ready, _, _ = select.select([self.fd], [], [], 0.1)
                if ready:
                    data = os.read(self.fd, 64)
                    if not data:
                        self.quit.set()
                        break
                    self.feed(data)
        finally:
            if old is not None:
                termios.tcsetattr(self.fd, termios.TCSADRAIN, old)


class Teleop:
    """Keys to wheel powers, stopping on a stale key.

    Args:
        keys: The key reader.
        limit: Speed limit as motor power (at most 0.15).
        stale_s: Stop when no key came for this long.
    """

    def __init__(self, keys: KeyReader, *, limit: float = 0.06, stale_s: float = 0.5) -> None:
        self.keys = keys
        self.limit = limit
        self.stale_s = stale_s

    def command(self, now: float) -> tuple[float, float, str]:
        """(left, right, what) for now."""
        for k in self.keys.take():
            if k == "faster":
                self.limit = min(MAX_POWER, round(self.limit + 0.01, 3))
            elif k == "slower":
                self.limit = max(0.01, round(self.limit - 0.01, 3))
        with self.keys.lock:
            key, at = self.keys.last, self.keys.at
        if key is None or now - at > self.stale_s or key in ("stop", "quit", "faster", "slower"):
            return 0.0, 0.0, "stopped" if key != "quit" else "quit"
        v, t = self.limit, 0.5 * self.limit
        return {
            "up": (v, v, "forward"),
            "down": (-v, -v, "back"),
            "left": (-t, t, "left"),
            "right": (t, -t, "right"),
        }[key]


def terminal_teleop(*, limit: float, stale_s: float) -> Teleop:
    """Drives by hand from this process's terminal: reads its keys in a thread; ``q`` stops the
    process as Ctrl-C does.

    Args:
        limit: Speed limit as motor power.
        stale_s: Stop when no key came for this long, s.

    Returns:
        The keys' drive.

    Raises:
        ValueError: When standard input is not a terminal.
    """
    if not os.isatty(sys.stdin.fileno()):
        raise ValueError("--teleop reads the keyboard: run it in a terminal (not from a scenario or a pipe)")
    keys = KeyReader(sys.stdin.fileno())
    threading.Thread(target=keys.run, name="keys", daemon=True).start()

    def quit_on_q() -> None:
        keys.quit.wait()
        os.kill(os.getpid(), signal.SIGINT)  # q: stop the agent as Ctrl-C does

    threading.Thread(target=quit_on_q, name="quit", daemon=True).start()
    return Teleop(keys, limit=limit, stale_s=stale_s)
