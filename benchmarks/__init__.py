"""Benchmarks: run outside the test suite; each prints its figures and their targets."""

from __future__ import annotations

import signal
import sys

__all__ = ["exit_on_sigterm"]


def exit_on_sigterm() -> None:
    """SIGTERM ends a benchmark as Ctrl-C does: its ``finally`` blocks run and stop, by pid,
    every process it started (killed without this, the driver left them running)."""
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
