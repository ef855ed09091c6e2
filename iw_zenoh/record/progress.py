"""How far a long job on a recording has gone, said on stderr (replay, resim, recover).

On a terminal, one line rewritten every second; otherwise (a log, a pipe) a line at every
10 %, and only once the job has taken a couple of seconds. A short job says nothing, stdout
(``--json``, a pipe into ``head``) is never touched, and a closed stderr silences it.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import IO

__all__ = ["Progress"]

TTY_EVERY_S = 1.0  # on a terminal, a new figure this often
QUIET_FOR_S = 2.0  # elsewhere, nothing from a job shorter than this
STEP = 0.1  # elsewhere, a line at every tenth


class Progress:
    """Says how far a job has gone.

    Args:
        prog: Who speaks (``iwz recover``).
        stream: Where (default stderr).
        tty: Whether it is a terminal (default: asks the stream).
        clock: Monotonic seconds (injected for tests).
    """

    def __init__(
        self,
        prog: str,
        *,
        stream: IO[str] | None = None,
        tty: bool | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.prog = prog
        self._out = stream if stream is not None else sys.stderr
        self._tty = tty if tty is not None else _isatty(self._out)
        self._clock = clock
        self._t0 = clock()
        self._last_t = self._t0
        self._next_step = STEP
        self._shown = False
        self._dead = False

    def update(self, fraction: float, detail: str = "") -> None:
        """Reports ``fraction`` (0 to 1) done, with ``detail`` (a time, a count), when it is due."""
        if self._dead:
            return
        now = self._clock()
        elapsed = now - self._t0
        if self._tty:
            if now - self._last_t < TTY_EVERY_S:
                return
        elif elapsed < QUIET_FOR_S or fraction < self._next_step:
            return
        self._last_t = now
        self._next_step = (int(fraction / STEP) + 1) * STEP
        pct = 100 * min(max(fraction, 0.0), 1.0)
        text = f"{self.prog}: {pct:3.0f} %{f' ({detail})' if detail else ''}, {elapsed:.0f} s"
        self._write(f"\r{text}\033[K" if self._tty else f"{text}\n")

    def done(self) -> None:
        """Ends the line a terminal was showing (nothing otherwise)."""
        if self._tty and self._shown:
            self._write("\n")
        self._shown = False

    def _write(self, text: str) -> None:
        try:
            self._out.write(text)
            self._out.flush()
            self._shown = True
        except (OSError, ValueError):  # stderr closed (a pipe gone): nobody is listening
            self._dead = True


def _isatty(stream: IO[str]) -> bool:
    try:
        return stream.isatty()
    except (OSError, ValueError):
        return False
