"""A :class:`~iw_zenoh.bus.Wake` that lets a burst of deliveries wake a loop once, when enough are in.

A lock-step world waits for every robot's actions of a tick. Each actions message used to set the
world loop's event: the loop woke, pumped every inbox, found the tick still waiting, and slept
again, up to once per robot, while the agents and the router needed the CPU. A
:class:`CountedWake` on the actions inbox counts deliveries instead and sets the loop's event only
once enough have come in to possibly complete the tick.

Only the wake-up is put off: the loop still pumps everything on every pass, and its periodic poll
still bounds how long a miscount could hold it (a duplicate or forged message counts too, so at
worst it wakes the loop early).
"""

from __future__ import annotations

import threading

__all__ = ["CountedWake"]

HELD = 1 << 62  # the target while held: no count reaches it


class CountedWake:
    """The wake of an inbox whose deliveries may be counted before they wake a loop.

    Released (the default), every delivery sets the loop's event as a plain event would. Held
    (:meth:`hold`), deliveries are counted and set nothing until :meth:`wake_after` names how many
    are needed; the event is set as soon as that many have come since a mark taken with
    :attr:`seen`, and by every delivery beyond. :meth:`release` makes every delivery wake at once
    again.

    Thread-safe: deliveries (``set``, on the bus's threads) and the loop's calls share a lock, so
    a target named while a delivery is being counted is never passed unseen.

    Args:
        event: The loop's event (what the inbox would set without this).
    """

    def __init__(self, event: threading.Event) -> None:
        self._event = event
        self._lock = threading.Lock()
        self._seen = 0  # deliveries counted, ever (while held or released)
        self._target: int | None = None  # None: released; else the count that wakes the loop

    @property
    def seen(self) -> int:
        """Deliveries counted so far: a mark for :meth:`wake_after`, taken before the loop drains
        the inbox (whatever came before the mark is drained then)."""
        return self._seen

    @property
    def held(self) -> bool:
        """Whether deliveries are being counted rather than waking the loop at once."""
        return self._target is not None

    def hold(self) -> None:
        """Deliveries from now on are counted and wake nothing until :meth:`wake_after`."""
        with self._lock:
            self._target = HELD

    def wake_after(self, mark: int, needed: int) -> None:
        """Held: sets the event once ``needed`` deliveries have come since ``mark`` (at once if
        they have already, or if ``needed`` is 0 or less).

        Args:
            mark: :attr:`seen` taken before the loop last drained the inbox.
            needed: How many more deliveries could complete what the loop waits for (each one
                answers at most one of the robots still expected).
        """
        with self._lock:
            self._target = mark + max(needed, 0)
            if self._seen >= self._target:
                self._event.set()

    def release(self) -> None:
        """Every delivery wakes the loop at once again (the event is left as it is: the loop pumps
        every inbox before it next waits)."""
        with self._lock:
            self._target = None

    def is_set(self) -> bool:
        """Released: whether the loop's event is set already; held: never (every delivery counts)."""
        return self._target is None and self._event.is_set()

    def set(self) -> None:
        """A delivery, on the bus's thread: counted; wakes the loop when released or the target is met."""
        with self._lock:
            self._seen += 1
            target = self._target
            if target is None or self._seen >= target:
                self._event.set()
