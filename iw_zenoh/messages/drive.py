"""The drive protocol: a person's input to a chair (``robot/{id}/drive``) and the chair's drive
state (``robot/{id}/driving``), which its own agent publishes (docs/driving.md).

Only the chair's own agent turns a driver's input into actions; a driver (the page through
``iwz view``, ``--input-trace``, a gamepad bridge) never publishes actions.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal

import msgspec

from iw_zenoh.messages.wire import COORD_LIMIT, Message, NonNeg, RobotId, _bounded

__all__ = ["ASSIST_LEVELS", "DEADMAN", "DRIVER_MAX", "LEVELS", "AssistLevel", "DriveInput", "DriveState"]

ASSIST_LEVELS = ("off", "safe", "assist")
AssistLevel = Literal["off", "safe", "assist"]
LEVELS = 5  # speed levels 1..LEVELS: level k allows k/LEVELS of the chair's maximum speed
DEADMAN = 1  # bit 0 of DriveInput.buttons: the dead-man button is held (the stick counts only then)
DRIVER_MAX = 64  # characters of a driver's name

Stick = Annotated[float, msgspec.Meta(ge=-1.0, le=1.0)]
Level = Annotated[int, msgspec.Meta(ge=1, le=LEVELS)]
Driver = Annotated[str, msgspec.Meta(max_length=DRIVER_MAX)]


def _point(name: str, p: tuple[float, float] | None) -> None:
    if p is not None:
        _bounded({f"{name}[0]": p[0], f"{name}[1]": p[1]}, COORD_LIMIT)
        if not (math.isfinite(p[0]) and math.isfinite(p[1])):
            raise ValueError(f"{name} must be finite, got {p!r}")


class DriveInput(Message, frozen=True, kw_only=True):
    """A driver's input to one chair, sent at a steady rate while driving (20 Hz from the page).

    The stick counts only while bit 0 of ``buttons`` (:data:`DEADMAN`) is held; an input with it
    clear is a zero stick. No input for 300 ms and the chair's agent zeroes the command (its
    dead-man). ``take`` takes the chair from another driver (explicit takeover); ``release``
    leaves it. ``goto`` hands the chair's planner a goal (world metres); a held stick cancels it.
    ``assist`` changes the shared-control level (``None``: keep it).
    """

    schema: ClassVar[str] = "iw.DriveInput/1"
    robot_id: RobotId
    driver: Annotated[str, msgspec.Meta(min_length=1, max_length=DRIVER_MAX)]
    seq: NonNeg = 0
    x: Stick = 0.0  # stick right
    y: Stick = 0.0  # stick forward
    buttons: Annotated[int, msgspec.Meta(ge=0, le=0xFFFF)] = 0
    level: Level = 1
    take: bool = False
    release: bool = False
    goto: tuple[float, float] | None = None
    assist: AssistLevel | None = None

    def __post_init__(self) -> None:
        """Refuses a stick beyond -1..1, NaN, and a goal beyond any lab."""
        for name, v in (("x", self.x), ("y", self.y)):
            if not -1.0 <= v <= 1.0:  # also NaN
                raise ValueError(f"{name} must be within -1..1, got {v!r}")
        _point("goto", self.goto)


class DriveState(Message, frozen=True, kw_only=True):
    """What the chair's agent does with its driver's input, each tick while it accepts a driver
    and on every change: who drives (``""``: nobody), the command after shared control
    (``v_mps``, ``w_radps``) and before (``input_*``), whether shared control changed it, the
    nearest obstacle its sensors see (``None``: nothing in range), the go-there goal, and
    ``stale`` when the dead-man tripped (no input for 300 ms)."""

    schema: ClassVar[str] = "iw.DriveState/1"
    robot_id: RobotId
    driver: Driver = ""
    seq: NonNeg = 0  # the driver's last input applied
    level: Level = 1
    assist: AssistLevel = "off"
    v_mps: float = 0.0
    w_radps: float = 0.0
    input_v_mps: float = 0.0
    input_w_radps: float = 0.0
    intervened: bool = False
    nearest_m: float | None = None
    goal: tuple[float, float] | None = None
    stale: bool = False
    refused: Driver = ""  # the last driver refused (the chair had another driver and no ``take``)

    def __post_init__(self) -> None:
        """Refuses speeds and distances beyond any chair's."""
        _bounded(
            {"v_mps": self.v_mps, "w_radps": self.w_radps, "input_v_mps": self.input_v_mps},
            COORD_LIMIT,
        )
        _bounded({"input_w_radps": self.input_w_radps, "nearest_m": self.nearest_m or 0.0}, COORD_LIMIT)
        _point("goal", self.goal)
