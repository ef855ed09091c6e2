"""Publishers declared once per key, and undeclared when their key has gone quiet.

A process that publishes on per-robot keys (sensors, radio, an agent host, a bridge) declares a
publisher for each robot's key the first time it publishes there. Robots come and go for hours:
without a bound the table would hold a publisher for every robot that ever was. This one holds
those used since its last sweep and at most ``capacity`` declared since; when it is about to
hold more, the publishers not used since the sweep before are undeclared (a key used again later
is simply declared again).

Publishing stays cheap: a dictionary look-up and a set insertion, no lock unless a publisher
is declared.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Generic, Protocol, TypeVar

__all__ = ["PUBLISHERS_KEPT", "Publishers", "Undeclarable"]

# publishers a process keeps before sweeping the quiet ones: well above any live set of per-robot
# keys of one process (1,000 chairs' sensors keys in one sensors node), so a sweep is rare
PUBLISHERS_KEPT = 4096


class Undeclarable(Protocol):
    """A declared publisher (or anything else that can be undeclared)."""

    def undeclare(self) -> None:
        """Gives it up."""


P = TypeVar("P", bound=Undeclarable)


class Publishers(Generic[P]):
    """Declared publishers by key, bounded by their keys in use.

    Args:
        declare: Declares the publisher of a key.
        capacity: Publishers declared between two sweeps: the table holds those used since the
            last sweep plus about ``capacity`` (a sweep waits for as many publishes as keys held,
            then looks at each publisher once: O(1) a publish however many keys are in use).
    """

    def __init__(self, declare: Callable[[str], P], capacity: int = PUBLISHERS_KEPT) -> None:
        self._declare = declare
        self.capacity = capacity
        self._limit = capacity
        self._pubs: dict[str, P] = {}
        self._used: set[str] = set()
        self._since = 0
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._pubs)

    def peek(self, key: str) -> P | None:
        """The publisher of ``key`` if one is declared (nothing declared, not noted as in use)."""
        return self._pubs.get(key)

    def get(self, key: str) -> P:
        """The publisher of ``key``, declared now if it has none (noted as in use either way)."""
        self._used.add(key)  # before the look-up: a sweep never takes a publisher being fetched
        self._since += 1  # publishes since the last sweep (approximate across threads: it only paces sweeps)
        pub = self._pubs.get(key)
        if pub is not None:
            return pub
        with self._lock:
            pub = self._pubs.get(key)
            if pub is None:
                # quiet is judged over at least as many publishes as keys held, so keys in use at
                # one rate (every robot each tick) are never swept, however many they are
                if len(self._pubs) >= self._limit and self._since >= len(self._pubs):
                    self._sweep()
                pub = self._pubs[key] = self._declare(key)
            return pub

    def _sweep(self) -> None:
        """Undeclares the publishers not used since the last sweep."""
        used, self._used = self._used, set()
        self._since = 0
        quiet = [k for k in self._pubs if k not in used]
        for k in quiet:
            self._pubs.pop(k).undeclare()
        self._limit = len(self._pubs) + self.capacity

    def clear(self) -> None:
        """Forgets every publisher (the session that declared them is closing)."""
        with self._lock:
            self._pubs.clear()
            self._used.clear()
