"""When the bridge sends each cycle's Measures: at a steady offset from the world's tick start.

The legacy server sends every robot's Measures at the start of each cycle, so a legacy agent sees
them exactly one period apart. Here a tick's readings reach the bridge after the world, the
collision process and the sensors process have each done their part, and how long that takes
varies from tick to tick with the load of the machine (at 100 robots on 2 cores: +16 ms at the
median, +25 ms at p99). Sending on arrival passes that variation on to every client.

So the Measures of tick n go out at ``tick_wall_ns(n) + offset``, where the offset is learned
from recent arrivals: a high percentile of their delays plus a margin, capped at a share of the
period so that agents keep the rest of the cycle to answer. It is recomputed every ``every``
ticks only, so it moves in rare small steps. Readings that arrive after their time are sent at
once. Delays beyond two periods (start-up, a stall) are not learned from: no offset could have
kept those in time. The world's clock and the bridge's are compared, so on two hosts they should
be synchronised (NTP); a negative delay is not learned from either.

Pure: no clock; the bridge passes times in.
"""

from __future__ import annotations

import collections

__all__ = ["Pacer"]


class Pacer:
    """Learns the send offset from the delays of arrivals.

    Args:
        period_ns: The world's tick period.
        window: Delays remembered.
        quantile: The share of remembered arrivals that must be in time.
        margin_ns: Added to that quantile.
        cap: The offset never exceeds ``cap * period`` (agents keep the rest of the cycle).
        every: Ticks between recomputations.
    """

    def __init__(
        self,
        period_ns: int,
        *,
        window: int = 200,
        quantile: float = 0.98,
        margin_ns: int = 2_000_000,
        cap: float = 0.7,
        every: int = 20,
    ) -> None:
        self.period_ns = period_ns
        self.quantile = quantile
        self.margin_ns = margin_ns
        self.cap = cap
        self.every = every
        self._delays: collections.deque[int] = collections.deque(maxlen=window)
        self._seen = 0
        self.offset_ns: int | None = None  # None until the first arrival

    def observe(self, delay_ns: int) -> None:
        """One tick's first readings arrived ``delay_ns`` after the world began that tick."""
        if not 0 <= delay_ns <= 2 * self.period_ns:
            return
        self._delays.append(delay_ns)
        self._seen += 1
        if self.offset_ns is None or self._seen % self.every == 0:
            d = sorted(self._delays)
            high = d[min(len(d) - 1, int(self.quantile * len(d)))]
            self.offset_ns = min(high + self.margin_ns, int(self.cap * self.period_ns))

    def due_ns(self, tick_wall_ns: int) -> int:
        """When the Measures of the tick that began at ``tick_wall_ns`` go out."""
        return tick_wall_ns + (self.offset_ns or 0)
