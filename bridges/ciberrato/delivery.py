"""When each robot's Measures go: at once, or, in a real-time world with pacing on, built shortly
before a steady offset from the tick's start and then sent all together (see :mod:`.pacing`).

No sockets and no clock of its own: the node passes times, a clock and what builds and sends.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence

from iw_zenoh.core.modes import Mode
from iw_zenoh.messages import SensorBatch, SensorReading, WorldInfo

from .pacing import Pacer
from .robot import LegacyRobot

__all__ = ["CATCH_UP", "MIN_LEAD_NS", "Delivery"]

logger = logging.getLogger(__name__)

CATCH_UP = 2  # readings of one robot sent at once after a stall (the rest are stale)
MIN_LEAD_NS = 2_000_000  # paced Measures are built at least this long before they are due

Build = Callable[[LegacyRobot, SensorReading], "bytes | None"]
Send = Callable[[LegacyRobot, bytes], None]


class Delivery:
    """The Measures waiting for their time, tick by tick.

    Args:
        pace: Pace real-time worlds' Measures (lock-step worlds' go at once).
    """

    def __init__(self, *, pace: bool) -> None:
        self.pace = pace
        self._pacer: Pacer | None = None
        self._paced_tick = -1
        self._due: dict[int, tuple[int, list[tuple[LegacyRobot, SensorReading]]]] = {}  # tick -> (when, to send)
        self._built: dict[int, list[tuple[LegacyRobot, bytes]]] = {}  # tick -> its Measures, built ahead
        self._lead_ns = MIN_LEAD_NS  # how long before their time Measures are built

    def pacer(self, info: WorldInfo | None) -> Pacer | None:
        """The pacer of a real-time world when pacing is on (lock-step waits for nobody's clock)."""
        if not self.pace or info is None or info.mode != Mode.REALTIME:
            return None
        if self._pacer is None or self._pacer.period_ns != info.period_ns:
            self._pacer = Pacer(info.period_ns)
        return self._pacer

    def arrived(
        self,
        batches: Sequence[SensorBatch],
        robots: Mapping[int, LegacyRobot],
        info: WorldInfo | None,
        now_ns: int,
    ) -> list[tuple[LegacyRobot, SensorReading]]:
        """Takes the readings that arrived; those to send at once (not paced, or nothing learned
        yet) are returned, the others wait for their time.

        A tick late is caught up; after a longer stall only the newest CATCH_UP go (never a burst
        of stale Measures that a client would read one by one).

        Args:
            batches: The sensors shards' batches, in arrival order.
            robots: The bridge's robots by id (others' readings are ignored).
            info: The world's description.
            now_ns: Wall-clock time of arrival.
        """
        pacer = self.pacer(info)
        newest: dict[int, list[SensorReading]] = {}
        for batch in batches:
            if pacer is not None and batch.tick_wall_ns and batch.tick > self._paced_tick:
                self._paced_tick = batch.tick  # the tick's first batch tells how late it came
                pacer.observe(now_ns - batch.tick_wall_ns)
            for r in batch.readings:
                if r.robot_id in robots:
                    newest.setdefault(r.robot_id, []).append(r)
        now: list[tuple[LegacyRobot, SensorReading]] = []
        for rid, readings in newest.items():
            robot = robots[rid]
            for reading in readings[-CATCH_UP:]:
                if pacer is None or pacer.offset_ns is None:
                    now.append((robot, reading))
                else:
                    due = self._due.setdefault(reading.tick, (pacer.due_ns(reading.tick_wall_ns), []))
                    due[1].append((robot, reading))
        return now

    def send_due(self, now_ns: int, build: Build, send: Send, clock: Callable[[], int]) -> None:
        """Builds each tick's Measures shortly before their time and sends them all at it.

        Building a hundred takes several milliseconds, and how many varies: built first and then
        sent in one tight loop, every robot's Measures leaves at the same point of each cycle.

        Args:
            now_ns: Wall-clock time now.
            build: A robot's Measures from a reading (None: none due).
            send: Sends a robot its Measures.
            clock: Wall-clock time in ns.
        """
        for tick in sorted(self._due):
            due, items = self._due[tick]
            if due - self._lead_ns > now_ns:
                break
            built = self._built.get(tick)
            if built is None:
                t0 = clock()
                built = self._built[tick] = []
                for robot, r in items:
                    data = build(robot, r)
                    if data is not None:
                        built.append((robot, data))
                now_ns = clock()
                self._lead_ns = max(MIN_LEAD_NS, (now_ns - t0) * 3 // 2 + MIN_LEAD_NS // 2)
            if due > now_ns:
                break  # built; the loop comes back within a millisecond to send
            del self._due[tick]
            del self._built[tick]
            for robot, data in built:
                send(robot, data)
            if logger.isEnabledFor(logging.DEBUG) and items:
                logger.debug(
                    "tick %d: %d Measures due %.1f ms after the tick began, sent %.1f ms after that, in %.1f ms",
                    tick,
                    len(built),
                    (due - items[0][1].tick_wall_ns) / 1e6,
                    (now_ns - due) / 1e6,
                    (clock() - now_ns) / 1e6,
                )
