"""What a study measures of a person's driving (docs/driving.md, "The study's rows"), from the
recorded drive channels: the raw input (``robot/{id}/drive``) and what the chair's agent did
with it (``robot/{id}/driving``). Pure: messages in, figures out.

* driver inputs: the inputs the chair received.
* commands given: the driver's distinct commands, as the seed counted a joystick's: each time the
  stick (dead-man held, beyond the dead zone) enters one of eight direction sectors from another
  sector or from the centre, each go-there goal and each speed-level or assist change.
* assistance intervened: simulation time during which shared control changed the driver's
  command (each drive state counts the time to the next of that chair, at most a tick's; a tick
  answered again between ticks counts as its last answer says).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from iw_zenoh.messages import DEADMAN, DriveInput, DriveState

__all__ = ["DriveFigures", "DriveMeter", "sector"]

CENTRE = 0.1  # a stick within this of its centre is centred (the chair's dead zone)
MAX_GAP_S = 0.5  # a drive state counts at most this long (a gap in the recording is not intervention)


def sector(msg: DriveInput) -> int:
    """The stick's direction: -1 centred (or the dead-man released), else 0..7 (0 forward,
    counter-clockwise, 45 degrees each)."""
    if not msg.buttons & DEADMAN or math.hypot(msg.x, msg.y) <= CENTRE:
        return -1
    return round(math.degrees(math.atan2(-msg.x, msg.y)) / 45.0) % 8


@dataclass(frozen=True)
class DriveFigures:
    """One chair's driving figures."""

    inputs: int
    commands: int
    intervened_s: float
    intervened_ticks: int


@dataclass
class _Chair:
    inputs: int = 0
    commands: int = 0
    sector: int = -1
    level: int = 0
    assist: str | None = None
    intervened_s: float = 0.0
    intervened_ticks: int = 0
    last_ns: int | None = None
    last_intervened: bool = False


class DriveMeter:
    """Follows the drive channels of a run, message by message."""

    def __init__(self) -> None:
        self.chairs: dict[int, _Chair] = {}

    def on_input(self, msg: DriveInput) -> None:
        """A driver's input."""
        c = self.chairs.setdefault(msg.robot_id, _Chair())
        c.inputs += 1
        s = sector(msg)
        if s >= 0 and s != c.sector:
            c.commands += 1
        c.sector = s
        if msg.goto is not None:
            c.commands += 1
        if c.level and msg.level != c.level:
            c.commands += 1
        c.level = msg.level
        if msg.assist is not None and msg.assist != c.assist:
            c.commands += c.assist is not None
            c.assist = msg.assist

    def on_state(self, msg: DriveState) -> None:
        """What a chair's agent did this tick."""
        c = self.chairs.setdefault(msg.robot_id, _Chair())
        if c.last_ns is not None and msg.sim_time_ns > c.last_ns and c.last_intervened:
            c.intervened_s += min(MAX_GAP_S, (msg.sim_time_ns - c.last_ns) / 1e9)
        if c.last_ns is None or msg.sim_time_ns > c.last_ns:
            c.last_ns = msg.sim_time_ns
            c.last_intervened = msg.intervened
            c.intervened_ticks += msg.intervened
        elif msg.sim_time_ns == c.last_ns:  # the tick answered again (an input between ticks): it stands
            c.intervened_ticks += msg.intervened - c.last_intervened
            c.last_intervened = msg.intervened

    def figures(self, robot_id: int) -> DriveFigures | None:
        """A chair's figures, or None when it was not driven by hand."""
        c = self.chairs.get(robot_id)
        if c is None:
            return None
        return DriveFigures(c.inputs, c.commands, c.intervened_s, c.intervened_ticks)
