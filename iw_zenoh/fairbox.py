"""``FairInbox``: an inbox bounded per key, so that one sender flooding its own key costs a
reader a bounded share of each pass and never pushes another key's messages out.

A plain :class:`~iw_zenoh.bus.Inbox` is one FIFO bounded as a whole: an agent flooding
``agent/NAME/actions`` filled the world's batch inbox, and the other agents' batches, the oldest
waiting, were the ones lost (their chairs stopped by the watchdog). Here each key keeps its own
newest ``per_key`` deliveries (a sender's newer batch holds its robots' newest commands), and
:meth:`FairInbox.drain` hands out every key's, so a flood costs the reader ``per_key`` messages a
pass whatever its rate.
"""

from __future__ import annotations

import collections
import threading

from iw_zenoh.bus import Delivery, Inbox, Wake

__all__ = ["FairInbox"]

KEYS_KEPT = 4_096  # keys with deliveries waiting at most (beyond, a new key's are lost and counted)


class FairInbox(Inbox):
    """An inbox that keeps at most the newest ``per_key`` deliveries of each key.

    Args:
        per_key: Deliveries of one key kept waiting at most.
        wake: Set on every delivery (as :class:`~iw_zenoh.bus.Inbox`'s).
        keys_kept: Keys with deliveries waiting at most.
    """

    def __init__(self, per_key: int, wake: Wake | None = None, *, keys_kept: int = KEYS_KEPT) -> None:
        super().__init__(maxlen=1, wake=wake, newest_only=True)
        self.per_key = per_key
        self.keys_kept = keys_kept
        self._lock = threading.Lock()
        self._by_key: dict[str, collections.deque[Delivery]] = {}
        self.dropped = 0  # deliveries pushed out by newer ones of their key, or of a key beyond keys_kept

    def put(self, item: Delivery) -> None:
        """Adds a delivery (called from the bus's thread)."""
        with self._lock:
            q = self._by_key.get(item[0])
            if q is None:
                if len(self._by_key) >= self.keys_kept:
                    self.dropped += 1
                    return
                q = self._by_key[item[0]] = collections.deque(maxlen=self.per_key)
            if len(q) == self.per_key:
                self.dropped += 1
            q.append(item)
            self.received += 1
        wake = self._wake
        if wake is not None and not wake.is_set():
            wake.set()

    def drain(self) -> list[Delivery]:
        """Every delivery waiting now: each key's, oldest first within a key."""
        if not self._by_key:
            return []
        with self._lock:
            by_key, self._by_key = self._by_key, {}
        out = [d for q in by_key.values() for d in q]
        self._taken += len(out)
        return out

    def get(self, timeout_s: float | None = None) -> Delivery | None:
        """Not for a fair inbox: its reader drains it."""
        raise NotImplementedError("a FairInbox is drained by its node loop (drain), not waited on")
