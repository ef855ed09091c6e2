"""How ``iwz run`` brings back a role that died: which exits are restarted, how often, after
what wait, and how long each role took to be back (its liveliness token seen again)."""

from __future__ import annotations

import threading
from dataclasses import dataclass, field

from iw_zenoh.launch.child import Child
from iw_zenoh.nodes.recorder import CANNOT_WRITE

__all__ = ["BACKOFF_S", "MAX_RESTARTS", "Restarts"]

MAX_RESTARTS = 3  # restarts of one role in a run; after them it stays down
BACKOFF_S = (0.0, 0.5, 2.0)  # wait before the first, second, third restart of one role


@dataclass
class Restarts:
    """The restarts of one run.

    Attributes:
        lost_at: Each child found dead and not yet restarted: when (monotonic s).
        waiting: Each child restarted whose liveliness token is not back yet: when it was found dead.
        recovered: Each role's times to recover (found dead to token back), in seconds.
    """

    lost_at: dict[str, float] = field(default_factory=dict)
    waiting: dict[str, float] = field(default_factory=dict)
    recovered: dict[str, list[float]] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock)  # tokens arrive on the bus's thread

    @staticmethod
    def restartable(c: Child, code: int) -> bool:
        """Whether a child that exited with ``code`` is started again: every role, unless it ended
        by itself (exit 0) where that is how it finishes (the world at its duration, an agent
        done); a router, a collision process or a recorder never finishes by itself (a restarted
        recorder writes the next part of the same recording: ``iwz record --continue``), but a
        recorder that could not write its file (the disk full) is not: its next part would be
        as empty."""
        return not (code == 0 and c.role in ("world", "agent") or code == CANNOT_WRITE and c.role == "record")

    @staticmethod
    def could_not_start(c: Child, code: int) -> bool:
        """Whether a child that exited with ``code`` could not start, which no restart mends and
        which ends the run (exit 3): on its first start, it ended with an error (not a signal)
        before its liveliness token was seen, or with 2 (its arguments, its file or its bus
        refused) or 3 (its robot refused) at any time of that start."""
        return c.restarts == 0 and code > 0 and (code in (2, 3) or not c.seen)

    def due(self, c: Child, now: float) -> bool:
        """Whether a dead child's wait before its next restart is over (noting when it was found dead)."""
        since = self.lost_at.setdefault(c.name, now)
        return now - since >= BACKOFF_S[min(c.restarts, len(BACKOFF_S) - 1)]

    def restarted(self, c: Child) -> None:
        """A child was started again: its token is now awaited."""
        c.restarts += 1
        with self._lock:
            self.waiting[c.name] = self.lost_at.pop(c.name)

    def on_alive(self, children: list[Child], role: str, name: str, now: float) -> str:
        """A liveliness token appeared: the restarted child it belongs to is back. Returns what to
        report ("" when it is no restarted child's)."""
        with self._lock:
            for c in children:
                if c.owns_token(role, name) and c.name in self.waiting:
                    took = now - self.waiting.pop(c.name)
                    self.recovered.setdefault(c.name, []).append(took)
                    return f"{c.name} is back {took:.2f} s after it was found dead"
        return ""
