"""A real chair on a serial link, as the wheelchair agent sees it: its serial bridge's readings.

``iwz bridge serial`` registers the chair, reports its odometry pose and publishes its own
readings (:class:`~iw_zenoh.messages.ChairReading`); the wheelchair agent attaches to that robot
(``--hardware serial --id N``), merges those readings with the virtual ones and publishes the
motor powers, which the bridge sends to the chair.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

from iw_zenoh.messages import ChairReading

__all__ = ["OwnReading", "SerialChair"]

HISTORY = 20  # readings kept (one a 50 ms board cycle: a second), to pair with the world's tick
TURN_M = 1.0  # pairing: a radian of heading counts as this far off (a cone's reading a metre out moves so much)


@dataclass(frozen=True)
class OwnReading:
    """The chair's own proximity readings and contact."""

    proximity_ids: list[int] = field(default_factory=list)
    proximity_m: list[float | None] = field(default_factory=list)
    collision: bool = False


class SerialChair:
    """The latest of a serial bridge's readings of its chair.

    Args:
        start: Where the chair starts (x, y, heading deg): its pose until the bridge reports one.
    """

    def __init__(self, start: tuple[float, float, float]) -> None:
        self.pose = start
        self.reading = OwnReading()
        self.link_up = False
        self.estop = False
        self._recent: deque[tuple[tuple[float, float, float], OwnReading]] = deque(maxlen=HISTORY)

    def update(self, msg: ChairReading) -> None:
        """Takes a reading from the bridge."""
        self.pose = msg.pose
        self.link_up = msg.link == "up"
        self.estop = msg.estop
        if self.link_up:
            self.reading = OwnReading(list(msg.proximity_ids), list(msg.proximity_m), any(msg.bumpers))
            self._recent.append((msg.pose, self.reading))

    def taken_at(self, pose: tuple[float, float, float]) -> OwnReading:
        """The recent reading taken nearest ``pose`` (the world's pose of a tick is one the bridge
        reported, so the chair's readings and the virtual ones then describe one instant).

        Heading counts as much as position: turning on the spot, every reading of the last second
        has the same position, and one taken 20 degrees ago would map the walls it saw 20 degrees
        round. Of equally near ones the newest wins.
        """
        if not self._recent:
            return self.reading

        def off(r: tuple[tuple[float, float, float], OwnReading]) -> float:
            turn = math.remainder(math.radians(r[0][2] - pose[2]), 2 * math.pi)
            return math.hypot(r[0][0] - pose[0], r[0][1] - pose[1], TURN_M * turn)

        return min(reversed(self._recent), key=off)[1]
