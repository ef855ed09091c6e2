"""Each cycle's says in that cycle's Measures: a tick's readings wait for the radio's hear lists of
the same tick (while a radio process is alive), as the legacy simulator delivers a cycle's says in
the ``Measures`` of that same cycle (``reference/ciberrato-protocol.md`` 4.3).

The radio and the sensors publish tick n independently (the radio as soon as the collision
verdict confirms the proposal, the sensors when the state comes), so either may reach the bridge
first. Readings that came first are held until the hear lists of their tick are in, or until a
deadline (a period in real time: at worst when the next tick begins); past it they go without (the
robots' Measures are not held back for ever), and what the lists then bring is counted as missed
(:meth:`LegacyRobot.next_measures`).

While the simulator is stopped (before Start, as after a Stop) no tick runs, so no radio delivers:
the legacy simulator still delivers a cycle's says in its stopped ``Measures`` (Time 0 before
Start), and so does the bridge, for its own robots, at the positions they stand
(:meth:`Hearing.stopped`).

Pure: no sockets, no bus, no clock; the node passes times and tells it which radios are alive.
"""

from __future__ import annotations

import collections
import logging
import math
from collections.abc import Mapping, Sequence

from iw_zenoh.core.modes import Mode
from iw_zenoh.messages import RadioBatch, SensorBatch, WorldInfo
from iw_zenoh.sim.radio import RadioConfig

from .robot import LegacyRobot

__all__ = ["LOCKSTEP_WAIT_NS", "TELL_EVERY_S", "TICKS_KEPT", "Hearing"]

logger = logging.getLogger(__name__)

TICKS_KEPT = 256  # ticks whose hear lists came, remembered (a tick older than these is long sent)
LOCKSTEP_WAIT_NS = 2_000_000_000  # lock-step waits for nobody's clock: only a radio that is stuck
TELL_EVERY_S = 1.0  # messages that missed their cycle are told at most this often
RANGE = RadioConfig().range_m  # the legacy simulator's: heard strictly closer than 8


class Hearing:
    """What the bridge's robots hear: the sensor batches waiting for their tick's hear lists, the
    says of a stopped simulator, and the messages that missed their cycle.

    Attributes:
        radios: Liveliness names of the radio processes alive (none: nothing waits).
        late: Ticks whose readings went without their hear lists, since last told.
    """

    def __init__(self) -> None:
        self.radios: set[str] = set()
        self.late: list[int] = []
        self.stopped_says: dict[int, str] = {}  # robot -> what it said while stopped (the last wins)
        self._told = -TELL_EVERY_S
        self._heard: collections.deque[int] = collections.deque(maxlen=TICKS_KEPT)
        self._heard_set: set[int] = set()
        self._held: list[tuple[int, SensorBatch]] = []  # (deadline, batch), in arrival order

    def on_alive(self, name: str, alive: bool) -> None:
        """A radio process's liveliness token came or went."""
        (self.radios.add if alive else self.radios.discard)(name)

    def take(self, delivered: Sequence[RadioBatch], robots: Mapping[int, LegacyRobot]) -> None:
        """The radio's hear lists: each robot's, kept for its tick's Measures."""
        for batch in delivered:
            self.heard(batch.tick)
            for hear in batch.hear:
                robot = robots.get(hear.robot_id)
                if robot is not None:
                    robot.heard[batch.tick] = [(h.sender, h.text) for h in hear.messages]

    def stopped(self, tick: int, robots: Mapping[int, LegacyRobot]) -> None:
        """The says of a stopped cycle heard in its Measures: by every robot of the bridge whose
        centre is strictly closer than the range to the speaker's (itself included), in sender
        order, as the legacy simulator delivers them."""
        says, self.stopped_says = self.stopped_says, {}
        for robot in robots.values():
            robot.heard[tick] = [
                (rid, text)
                for rid, text in sorted(says.items())
                if rid in robots and math.dist(robot.pose, robots[rid].pose) < RANGE
            ]

    def missed(self, robots: Mapping[int, LegacyRobot], now_s: float) -> tuple[int, str]:
        """How many messages missed their cycle since last told (at most every TELL_EVERY_S) and
        why, or ``(0, "")``; the robots' counts start again."""
        if now_s - self._told < TELL_EVERY_S:
            return 0, ""
        n = sum(r.missed for r in robots.values())
        if not n and not self.late:
            return 0, ""
        self._told = now_s
        late, self.late = self.late, []
        for r in robots.values():
            r.missed = 0
        return n, (
            f"{n} heard messages missed their cycle: the radio's hear lists came after the Measures of their "
            f"tick were sent (ticks whose readings did not wait for them: {late[:10]})"
        )

    def heard(self, tick: int) -> None:
        """The radio's hear lists of ``tick`` are in."""
        if tick in self._heard_set:
            return
        if len(self._heard) == self._heard.maxlen:
            self._heard_set.discard(self._heard[0])
        self._heard.append(tick)
        self._heard_set.add(tick)

    @staticmethod
    def wait_ns(info: WorldInfo | None) -> int:
        """How long a tick's readings may wait for its hear lists: a period in real time (late
        Measures, as the legacy simulator's on a busy machine, rather than a message lost)."""
        if info is None or info.mode == Mode.LOCKSTEP:
            return LOCKSTEP_WAIT_NS
        return info.period_ns

    def ready(self, batches: Sequence[SensorBatch], info: WorldInfo | None, now_ns: int) -> list[SensorBatch]:
        """The batches that may go now, in arrival order: every one when no radio is alive, else
        those whose tick's hear lists are in and those past their deadline (noted in :attr:`late`).

        Args:
            batches: The batches that just arrived.
            info: The world's description (its mode and period).
            now_ns: Monotonic time now.
        """
        deadline = now_ns + self.wait_ns(info)
        waiting = self._held + [(deadline, b) for b in batches]
        if not self.radios:
            self._held = []
            return [b for _, b in waiting]
        out: list[SensorBatch] = []
        self._held = []
        for due, b in waiting:
            if b.tick in self._heard_set:
                out.append(b)
            elif now_ns >= due:
                out.append(b)
                if b.tick not in self.late:
                    self.late.append(b.tick)
            else:
                self._held.append((due, b))
        return out

    @property
    def holding(self) -> bool:
        """Whether some batch waits."""
        return bool(self._held)
