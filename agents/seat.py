"""The driver's seat of a chair: who drives it, their last input, and the dead-man; pure (the
time is handed in).

* One driver at a time: the first input takes a free chair; input from anyone else is refused
  (and named in the drive state) unless it says ``take``; ``release`` frees the chair.
* Dead-man: no input for DEADMAN_S and the stick reads zero (``stale``), and a go-there goal
  stops too; the stick counts only while the input's dead-man bit is held.
* A driver silent for FREE_AFTER_S leaves the seat (anyone may take it without ``take``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from iw_zenoh.messages import ASSIST_LEVELS, DEADMAN, DriveInput

__all__ = ["DEADMAN_S", "FREE_AFTER_S", "DriverSeat", "Stick"]

DEADMAN_S = 0.3  # no input this long: the command is zero (the world's own watchdog is 0.5 s)
FREE_AFTER_S = 10.0  # a driver silent this long has gone: the seat is free
GRAB = 0.1  # a stick pushed this far (dead-man held) is the driver's hand back: a go-there goal ends


@dataclass(frozen=True)
class Stick:
    """The driver's stick now: x right, y forward (zero unless live), and whether the seat's
    input is stale (the dead-man tripped)."""

    x: float
    y: float
    stale: bool


class DriverSeat:
    """Arbitrates a chair's drivers.

    Args:
        robot_id: The chair.
        level: Speed level until a driver says.
        assist: Shared-control level until a driver says.
        deadman_s: The dead-man's delay.
    """

    def __init__(self, robot_id: int, *, level: int = 1, assist: str = "off", deadman_s: float = DEADMAN_S) -> None:
        if assist not in ASSIST_LEVELS:
            raise ValueError(f"assist must be one of {', '.join(ASSIST_LEVELS)}, got {assist!r}")
        self.robot_id = robot_id
        self.level = level
        self.assist = assist
        self.deadman_s = deadman_s
        self.driver = ""
        self.last: DriveInput | None = None
        self.last_at = -math.inf
        self.goal: tuple[float, float] | None = None
        self.refused = ""
        self.inputs = 0  # inputs accepted (a study's "commands given" counts the pushes, below)
        self.pushes = 0  # times the stick was pushed out of the centre

    def offer(self, msg: DriveInput, now_s: float) -> bool:
        """A driver's input at ``now_s``; whether it was accepted (refused: another drives)."""
        if msg.robot_id != self.robot_id:
            return False
        if self.driver and msg.driver != self.driver and not msg.take and now_s - self.last_at < FREE_AFTER_S:
            if not msg.release:
                self.refused = msg.driver
            return False
        if msg.release:
            if msg.driver == self.driver or msg.take:
                self.driver, self.last, self.goal = "", None, None
            return True
        if msg.driver != self.driver:
            self.goal = None  # a new driver starts from nothing the last one asked
        was = self._pushed(self.last) and self.last is not None and self.last.driver == msg.driver
        self.driver, self.last, self.last_at = msg.driver, msg, now_s
        self.inputs += 1
        self.level = msg.level
        if msg.assist is not None:
            self.assist = msg.assist
        if msg.goto is not None:
            self.goal = msg.goto
        elif self._pushed(msg):
            self.goal = None
        if self._pushed(msg) and not was:
            self.pushes += 1
        return True

    @staticmethod
    def _pushed(msg: DriveInput | None) -> bool:
        return msg is not None and bool(msg.buttons & DEADMAN) and math.hypot(msg.x, msg.y) > GRAB

    def stale(self, now_s: float) -> bool:
        """Whether the dead-man has tripped (a driver, and no input for ``deadman_s``)."""
        return bool(self.driver) and now_s - self.last_at > self.deadman_s

    def stick(self, now_s: float) -> Stick:
        """The stick now: the last input's while the dead-man bit is held and it is fresh, zero
        otherwise. A driver silent for FREE_AFTER_S leaves the seat."""
        if self.driver and now_s - self.last_at > FREE_AFTER_S:
            self.driver, self.last, self.goal = "", None, None
        m = self.last
        if m is None or not self.driver:
            return Stick(0.0, 0.0, stale=False)
        if self.stale(now_s):
            return Stick(0.0, 0.0, stale=True)
        if not m.buttons & DEADMAN:
            return Stick(0.0, 0.0, stale=False)
        return Stick(m.x, m.y, stale=False)
