"""Clocks, injected into every node so tests can drive time."""

from __future__ import annotations

import threading
import time
from typing import Protocol

__all__ = ["Clock", "WallClock"]


class Clock(Protocol):
    """A source of time."""

    def now_ns(self) -> int:
        """Monotonic time, ns."""

    def wall_ns(self) -> int:
        """Wall-clock time since the epoch, ns (for log times)."""

    def wait(self, event: threading.Event, timeout_s: float) -> bool:
        """Waits for ``event`` or ``timeout_s``; True if the event was set."""


class WallClock:
    """The real clock."""

    def now_ns(self) -> int:
        """Monotonic time, ns."""
        return time.monotonic_ns()

    def wall_ns(self) -> int:
        """Wall-clock time, ns."""
        return time.time_ns()

    def wait(self, event: threading.Event, timeout_s: float) -> bool:
        """Waits on a real event."""
        return event.wait(max(0.0, timeout_s))
