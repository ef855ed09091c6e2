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
import logging
import threading
import time
from collections.abc import Callable

from iw_zenoh.bus import LOST_LOG_S, Delivery, Inbox, Wake

__all__ = ["FairInbox"]

logger = logging.getLogger(__name__)

KEYS_KEPT = 4_096  # keys with deliveries waiting at most (beyond, a new key's are lost and counted)
STRANGERS_KEPT = 64  # keys ``known`` does not know with deliveries waiting, at most (enough to report them)


class FairInbox(Inbox):
    """An inbox that keeps at most the newest ``per_key`` deliveries of each key.

    Its :attr:`lost` counts every delivery dropped (pushed out by a newer one of its key, or of a
    key beyond the bounds); :meth:`drain` logs the drops at most once a second, with their count.

    Args:
        per_key: Deliveries of one key kept waiting at most.
        wake: Set on every delivery (as :class:`~iw_zenoh.bus.Inbox`'s).
        keys_kept: Keys with deliveries waiting at most.
        known: Whether a key is one the reader expects (the world: a robot it holds); keys it
            does not know take at most ``strangers_kept`` places, never one of ``keys_kept``, so
            invented keys by the thousand push no known key's deliveries out.
        strangers_kept: Unknown keys with deliveries waiting at most.
        name: What the inbox holds, for the log.
    """

    def __init__(
        self,
        per_key: int,
        wake: Wake | None = None,
        *,
        keys_kept: int = KEYS_KEPT,
        known: Callable[[str], bool] | None = None,
        strangers_kept: int = STRANGERS_KEPT,
        name: str = "a fair inbox",
    ) -> None:
        super().__init__(maxlen=1, wake=wake, newest_only=True)
        self.per_key = per_key
        self.keys_kept = keys_kept
        self.known = known
        self.strangers_kept = strangers_kept
        self.name = name
        self._lock = threading.Lock()
        self._by_key: dict[str, collections.deque[Delivery]] = {}
        self._strangers = 0  # keys waiting that ``known`` did not know
        self._logged_lost = 0  # drops already logged

    @property
    def dropped(self) -> int:
        """Deliveries dropped so far (as :attr:`lost`)."""
        return self.lost

    def put(self, item: Delivery) -> None:
        """Adds a delivery (called from the bus's thread)."""
        with self._lock:
            q = self._by_key.get(item[0])
            if q is None:
                stranger = self.known is not None and not self.known(item[0])
                if stranger:
                    full = self._strangers >= self.strangers_kept
                else:
                    full = len(self._by_key) - self._strangers >= self.keys_kept
                if full:
                    self.lost += 1
                    return
                self._strangers += stranger
                q = self._by_key[item[0]] = collections.deque(maxlen=self.per_key)
            if len(q) == self.per_key:
                self.lost += 1
            q.append(item)
            self.received += 1
        if self._waiters:
            with self._cv:
                self._cv.notify_all()
        wake = self._wake
        if wake is not None and not wake.is_set():
            wake.set()

    def drain(self) -> list[Delivery]:
        """Every delivery waiting now: each key's, oldest first within a key."""
        if self.lost > self._logged_lost:
            self._log_lost()
        if not self._by_key:
            return []
        with self._lock:
            by_key, self._by_key, self._strangers = self._by_key, {}, 0
        out = [d for q in by_key.values() for d in q]
        self._taken += len(out)
        return out

    def _log_lost(self) -> None:
        now = time.monotonic()
        if now - self._logged >= LOST_LOG_S:
            self._logged = now
            logger.warning(
                "%s dropped %d deliveries since the last report (%d so far): a key sent more than %d a pass, "
                "or more keys than %d were waiting",
                self.name,
                self.lost - self._logged_lost,
                self.lost,
                self.per_key,
                self.keys_kept,
            )
            self._logged_lost = self.lost

    def get(self, timeout_s: float | None = None) -> Delivery | None:
        """Not for a fair inbox: its reader drains it."""
        raise NotImplementedError("a FairInbox is drained by its node loop (drain), not waited on")

    def wait(self, timeout_s: float) -> bool:
        """Waits until something is waiting; False on timeout."""
        with self._cv:
            self._waiters += 1
            try:
                return self._cv.wait_for(lambda: bool(self._by_key), timeout=timeout_s)
            finally:
                self._waiters -= 1

    def __len__(self) -> int:
        with self._lock:
            return sum(len(q) for q in self._by_key.values())
