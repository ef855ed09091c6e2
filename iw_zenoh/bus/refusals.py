"""Refusals reported at a bounded rate: at most one report (an event and a log line) per source
and reason each period, carrying how many refusals it stands for.

A buggy or hostile sender flooding one key with bad messages used to cost one event and one log
line per message (a hundred thousand events in seconds on the bus, every other process reading
them). :class:`RefusalLimiter` decides which refusals are reported: the first of a (source,
reason) in a period at once, the rest counted into the next report (or :meth:`RefusalLimiter.due`'s
once the period is over and nothing more came). The caller gives the time; a lock lets several
threads of one process (a serial thread, Zenoh's callbacks, the main loop) share one limiter.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

__all__ = ["PERIOD_NS", "Pending", "RefusalLimiter", "counted"]

PERIOD_NS = 1_000_000_000  # one report per source and reason each second
SOURCES_KEPT = 1_024  # (source, reason) pairs remembered; forged keys by the million cost no memory
REPORTS_PER_PERIOD = 64  # reports of every source together each period, beyond which they are counted


@dataclass
class Pending:
    """A (source, reason) reported at ``reported_ns``, and the refusals counted since, not reported."""

    reported_ns: int
    counted: int = 0
    example: str = ""  # the reason of the last one counted (the report says it)


class RefusalLimiter:
    """Which refusals to report, and with what count.

    Args:
        period_ns: At most one report per source and reason in this long.
        kept: Pairs remembered at most (beyond, the oldest half is forgotten).
        reports_per_period: Reports of all sources together in a period at most (a flood spread
            over many keys is bounded as well); the rest are counted under ``("*", reason)``.
    """

    def __init__(
        self, period_ns: int = PERIOD_NS, kept: int = SOURCES_KEPT, reports_per_period: int = REPORTS_PER_PERIOD
    ) -> None:
        self.period_ns = period_ns
        self.kept = kept
        self.reports_per_period = reports_per_period
        self._pending: dict[tuple[str, str], Pending] = {}
        self._window = (0, 0)  # (period start, reports in it)
        self._lock = threading.Lock()  # admit and due from several threads: one at a time
        self.refused = 0  # every refusal seen
        self.reported = 0  # reports made

    def admit(self, source: str, reason: str, now_ns: int, text: str = "") -> int:
        """One refusal from ``source`` for ``reason`` (a short category, e.g. ``malformed``).

        Args:
            source: Who it came from (a key).
            reason: Its category.
            now_ns: Now.
            text: What to say of it (kept as the example of those counted).

        Returns:
            0 when it is only counted; else how many refusals the report made now stands for
            (this one and those counted since the last report).
        """
        with self._lock:
            return self._admit(source, reason, now_ns, text)

    def _admit(self, source: str, reason: str, now_ns: int, text: str) -> int:
        self.refused += 1
        start, n = self._window
        if now_ns - start >= self.period_ns:
            start, n = now_ns, 0
        pair = (source, reason)
        p = self._pending.get(pair)
        if p is not None and now_ns - p.reported_ns < self.period_ns:
            p.counted += 1
            p.example = text
            return 0
        if n >= self.reports_per_period:  # too many sources this period: counted together
            self._window = (start, n)
            if pair in self._pending:
                self._pending[pair].counted += 1
                return 0
            return self._count(("*", reason), now_ns, text)
        self._window = (start, n + 1)
        count = 1 + (p.counted if p is not None else 0)
        self._remember(pair, Pending(now_ns))
        self.reported += 1
        return count

    def _count(self, pair: tuple[str, str], now_ns: int, text: str) -> int:
        p = self._pending.get(pair)
        if p is None:
            p = Pending(now_ns - self.period_ns)  # reported by due() once its period is over
            self._remember(pair, p)
        p.counted += 1
        p.example = text
        return 0

    def _remember(self, pair: tuple[str, str], p: Pending) -> None:
        if pair not in self._pending and len(self._pending) >= self.kept:
            olds = [pair for pair in self._pending if pair[0] != "*"]  # ("*", reason) stay: one per reason
            for old in olds[: self.kept // 2]:  # oldest first (insertion order)
                gone = self._pending.pop(old)
                if gone.counted:  # counted, not reported: said under ("*", reason), not lost
                    star = self._pending.get(("*", old[1]))
                    if star is None:
                        star = self._pending[("*", old[1])] = Pending(gone.reported_ns)
                    star.counted += gone.counted
                    star.example = gone.example
        self._pending.pop(pair, None)
        self._pending[pair] = p

    def due(self, now_ns: int) -> list[tuple[str, str, int, str]]:
        """The refusals counted and not yet reported whose period is over: ``(source, reason,
        count, example)`` each, to report now (a flood that stopped still has its count said)."""
        out = []
        with self._lock:
            for pair, p in list(self._pending.items()):  # a copy: nothing changes it under us
                if p.counted and now_ns - p.reported_ns >= self.period_ns:
                    out.append((*pair, p.counted, p.example))
                    p.counted, p.reported_ns = 0, now_ns
                    self.reported += 1
        return out


def counted(text: str, count: int) -> str:
    """A refusal's report: ``text``, and how many more like it it stands for."""
    return text if count <= 1 else f"{text} (and {count - 1} more like it on this key since the last report)"
