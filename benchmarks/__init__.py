"""Benchmarks: run outside the test suite; each prints its figures and their targets."""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Sequence

__all__ = ["exit_on_sigterm", "stop_all"]


def exit_on_sigterm() -> None:
    """SIGTERM ends a benchmark as Ctrl-C does: its ``finally`` blocks run and stop, by pid,
    every process it started (killed without this, the driver left them running)."""
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))


def stop_all(procs: Sequence[subprocess.Popen[bytes]], timeout_s: float = 20.0) -> None:
    """Stops processes a benchmark started: SIGTERM to each (the last started first), then a
    kill for any still up after ``timeout_s``."""
    for p in reversed(procs):
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    for p in reversed(procs):
        try:
            p.wait(timeout_s)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(5)
