"""How far ahead of the world a message's tick may be (pure: the receiver passes its clock in).

Ticks go up by one a tick. A receiver that keeps per-tick state (an agent host that ignores
readings older than the newest it saw, a sensors node that computes the next tick ahead, a world
that counts which tick each robot answered) would be deafened for good by one forged tick of
10**15 if it adopted it. So a tick is refused, with its reason, when it is more than
:data:`WINDOW_TICKS` ahead of the world's tick as the receiver knows it: the world's own tick for
the world; for the others the newest tick they accepted (or the world's answer to a registration
or an info query), plus what the world can have stepped since, at most :data:`MAX_TICKS_PER_S`
(a receiver that was stalled, stopped or busy, catches up; the price: a message forged after a
long silence, a paused world, may be that much further ahead). Ticks behind are not refused: every
receiver already tells a late message from a current one.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Generic, Protocol, TypeVar

__all__ = ["MAX_TICKS_PER_S", "WINDOW_TICKS", "TickWindow", "ViewWindow", "too_far_ahead"]

WINDOW_TICKS = 100  # a forged tick within the window deafens for at most this many ticks (10 s at 100 ms)
MAX_TICKS_PER_S = 200  # a real-time world ticks slower (5 ms period); lock-step waits for its receivers


def too_far_ahead(tick: int, current: int, window: int = WINDOW_TICKS) -> str:
    """Why ``tick`` is refused by a receiver whose world is at ``current``, or ``""``.

    Args:
        tick: The message's tick.
        current: The world's tick as the receiver knows it.
        window: How many ticks ahead a message may be.

    Returns:
        The reason, naming both ticks and the window; empty when the tick is within it.
    """
    if tick > current + window:
        return f"tick {tick} is {tick - current} ticks ahead of the world's tick {current} (at most {window} may be)"
    return ""


class TickWindow:
    """The world's tick as one receiver knows it, and the window the ticks it accepts fall in.

    Args:
        window: Ticks a message may be ahead of the newest accepted.
        rate_per_s: Ticks the world may have stepped per second since then.
    """

    def __init__(self, *, window: int = WINDOW_TICKS, rate_per_s: float = MAX_TICKS_PER_S) -> None:
        self.window = window
        self.rate_per_s = rate_per_s
        self.newest: int | None = None  # None: nothing known yet, the first tick is taken
        self._at_ns = 0

    def anchor(self, tick: int, now_ns: int) -> None:
        """Takes the world's own word for its tick (a registration answer, an info answer).

        Args:
            tick: The world's tick.
            now_ns: The receiver's monotonic clock (ns).
        """
        self.newest, self._at_ns = tick, now_ns

    def refuse(self, tick: int, now_ns: int) -> str:
        """Why ``tick`` is refused, or ``""``: then it is accepted and the window follows it.

        Args:
            tick: A message's tick.
            now_ns: The receiver's monotonic clock (ns).

        Returns:
            The reason (see :func:`too_far_ahead`), or empty.
        """
        if self.newest is None:
            self.anchor(tick, now_ns)
            return ""
        why = self.ahead(tick, now_ns)
        if not why and tick >= self.newest:
            self.newest, self._at_ns = tick, now_ns
        return why

    def ahead(self, tick: int, now_ns: int) -> str:
        """Why ``tick`` is too far ahead, or ``""``, leaving the window where it is: for a message
        that follows the world's tick without setting it (a collision verdict).

        Args:
            tick: A message's tick.
            now_ns: The receiver's monotonic clock (ns).

        Returns:
            The reason (see :func:`too_far_ahead`); empty when it is within, or nothing is known yet.
        """
        if self.newest is None:
            return ""
        stepped = int(max(0, now_ns - self._at_ns) * self.rate_per_s / 1e9)
        return too_far_ahead(tick, self.newest, self.window + stepped)


class _Info(Protocol):
    @property
    def tick(self) -> int: ...
    @property
    def revision(self) -> int: ...


class _View(Protocol):
    @property
    def info(self) -> _Info: ...
    @property
    def specs(self) -> Mapping[int, object]: ...


class _Batched(Protocol):
    @property
    def tick(self) -> int: ...
    @property
    def revision(self) -> int: ...
    @property
    def ids(self) -> list[int]: ...


V = TypeVar("V", bound=_View)


class ViewWindow(Generic[V]):
    """For a node that computes batched messages (states, proposals) in a view of the world: the
    view to compute one in, when its tick is within the window (anchored on each new view's tick,
    the world's answer) and every robot it names is in the view.

    Args:
        get: The view at a revision or newer, or None when the world does not answer.
    """

    def __init__(self, get: Callable[[int], V | None]) -> None:
        self._get = get
        self.ticks = TickWindow()
        self._anchored: V | None = None

    def view(self, msg: _Batched, now_ns: int) -> tuple[V | None, str]:
        """The view to compute ``msg`` in.

        Args:
            msg: A state or proposal.
            now_ns: The receiver's monotonic clock (ns).

        Returns:
            ``(view, "")`` to compute it; ``(None, reason)`` to refuse it as bad; ``(None, "")``
            when it cannot be computed for now (no world info, or a roster that moved on since).
        """
        view = self._get(msg.revision)
        if view is None:
            return None, ""
        if view is not self._anchored:
            self._anchored = view
            self.ticks.anchor(view.info.tick, now_ns)
        why = self.ticks.refuse(msg.tick, now_ns)
        if why:
            return None, why
        unknown = [i for i in msg.ids if i not in view.specs]
        if unknown and view.info.revision == msg.revision:
            return None, f"robots {unknown[:5]} are not in the world's revision {msg.revision}"
        return (None, "") if unknown else (view, "")
