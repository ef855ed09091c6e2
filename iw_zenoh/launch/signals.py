"""How ``iwz run`` takes SIGTERM and SIGHUP: the same ordered stop as Ctrl-C, and, when its
terminal was closed, nothing more written to it (every write to a hung-up terminal fails)."""

from __future__ import annotations

import os
import signal
import threading

__all__ = ["stop_on_signals"]


def stop_on_signals(stop: threading.Event) -> None:
    """SIGTERM and SIGHUP set ``stop``: the same ordered stop as Ctrl-C, not a launcher killed."""
    ttys = [fd for fd in (1, 2) if os.isatty(fd)]  # asked now: a terminal hung up is no longer one

    def on_term(signum: int, _frame: object) -> None:
        if signum == signal.SIGHUP:  # its terminal closed, perhaps: what it writes there goes nowhere
            _to_devnull(ttys)
        stop.set()

    signal.signal(signal.SIGTERM, on_term)
    signal.signal(signal.SIGHUP, on_term)


def _to_devnull(fds: list[int]) -> None:
    """Points ``fds`` at /dev/null: on a terminal that was closed every write fails (EIO), and the
    status line or the summary would end an ordered stop with a traceback and exit 1."""
    null = os.open(os.devnull, os.O_WRONLY)
    for fd in fds:
        os.dup2(null, fd)
    os.close(null)
