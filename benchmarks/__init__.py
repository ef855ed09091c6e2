"""Benchmarks: run outside the test suite; each prints its figures and their targets."""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

__all__ = ["exit_on_sigterm", "stop_all", "workdir"]


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


def workdir(logs: str | None, name: str, prefix: str = "iwz-bench-") -> contextlib.AbstractContextManager[str]:
    """A scratch directory for one measurement's files: ``logs/name``, kept, when ``logs`` is
    given; else a temporary one (``prefix``), removed after it."""
    if logs:
        path = Path(logs) / name
        path.mkdir(parents=True, exist_ok=True)
        return contextlib.nullcontext(str(path))
    return tempfile.TemporaryDirectory(prefix=prefix)
