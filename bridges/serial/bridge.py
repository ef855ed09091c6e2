"""The serial bridge's logic: safety rules, odometry and what goes on the wire (pure; time passed in).

Rules (``docs/serial.md``):

* a command is fresh for :data:`STALE_S` after the agent's last action; after that the bridge
  sends zero powers (agent silent, world gone, bus lost: the same);
* an e-stop, from the operator or from the chair, latches: the bridge sends EStop every cycle
  until an operator clears it, and a clear is followed by zero powers until a fresh action;
* the link is down when the line fails or no good Status came for :data:`LINK_TIMEOUT_S`; the
  odometry keeps its pose (the robot is held where it was) and picks the encoder counts up again
  from the first Status after the link returns;
* a Status the chair cannot have sent is refused (:meth:`BridgeCore.implausible`): an encoder
  step beyond what the chair's top speed allows since the last Status (the odometry takes the
  new counts as its baseline and does not move), a battery outside :data:`BATTERY_V`, a range
  beyond :data:`RANGE_MAX_MM`; while they go on for :data:`HOLD_AFTER_S`, the chair is held
  (zero powers) until a plausible Status comes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from iw_zenoh.core.odometry import WheelOdometry

from .protocol import (
    FLAG_ESTOP,
    FLAG_ESTOP_BOARD,
    FLAG_WATCHDOG,
    NO_RANGE,
    Clear,
    EStop,
    Message,
    Motors,
    Status,
    power_from_units,
    power_to_units,
)

__all__ = [
    "BATTERY_V",
    "HOLD_AFTER_S",
    "LINK_TIMEOUT_S",
    "RANGE_MAX_MM",
    "STALE_S",
    "BridgeCore",
    "Snapshot",
    "WheelOdometry",
    "ranges_m",
    "watchdog",
    "wheels",
]

STALE_S = 0.2  # no fresh action for this long: command zero
LINK_TIMEOUT_S = 0.3  # no good Status for this long: the link is down (the board sends every 50 ms)
SPEED_MARGIN = 2.0  # an encoder step up to twice the top speed's is plausible (slip, a fast wheel)
STEP_SLACK = 100  # and this many counts more (the board's own jitter)
MIN_FRAME_S = 0.1  # the time a step is judged over, at least (frames read in a burst)
BATTERY_V = (8.0, 40.0)  # a powered chair's battery (24 V nominal) reads within this while it runs
RANGE_MAX_MM = 20_000  # no proximity sensor on a chair reads farther
HOLD_AFTER_S = 0.3  # implausible Status for this long: the chair is held


@dataclass(frozen=True)
class Snapshot:
    """The chair as the bridge last heard it."""

    pose: tuple[float, float, float]
    status: Status | None
    link_up: bool
    estop: bool
    estop_source: str


class BridgeCore:
    """Commands, e-stop latch, link state and odometry of one chair.

    Args:
        odometry: The chair's odometry.
    """

    def __init__(self, odometry: WheelOdometry, max_speed_mps: float = math.inf) -> None:
        self.odometry = odometry
        self.max_counts_per_s = max_speed_mps * odometry.per_m * SPEED_MARGIN
        self.counts: tuple[int, int] | None = None  # the last encoder counts taken (None: a new baseline)
        self.implausible_s: float | None = None  # since when every Status was refused (None: not)
        self.command = (0.0, 0.0)
        self.action_s = -math.inf
        self.status: Status | None = None
        self.status_s = -math.inf
        self.estop = False
        self.estop_source = ""
        self.clear_pending = False
        self.line_ok = False

    def on_action(self, left: float, right: float, now_s: float) -> None:
        """The agent's command."""
        self.command = (left, right)
        self.action_s = now_s

    def on_estop(self) -> None:
        """The operator's e-stop."""
        self.estop, self.estop_source = True, self.estop_source or "computer"

    def on_clear(self) -> None:
        """The operator clears the e-stop; the chair waits for a fresh action."""
        self.estop, self.estop_source = False, ""
        self.clear_pending = True
        self.action_s = -math.inf

    def implausible(self, status: Status, now_s: float) -> tuple[str, str]:
        """Why the chair cannot have sent ``status``: ``(what, reason)``, or ``("", "")``.

        ``what`` is ``encoders``, ``battery`` or ``ranges``.
        """
        v = status.battery_mv / 1000
        if not BATTERY_V[0] <= v <= BATTERY_V[1]:
            return "battery", f"battery {v:g} V, outside {BATTERY_V[0]:g}-{BATTERY_V[1]:g} V"
        far = [r for r in status.ranges_mm if r != NO_RANGE and r > RANGE_MAX_MM]
        if far:
            return "ranges", f"range {far[0]} mm, beyond {RANGE_MAX_MM} mm"
        if self.counts is not None:
            dt = max(now_s - self.status_s, MIN_FRAME_S)
            limit = self.max_counts_per_s * dt + STEP_SLACK
            step = max(abs(_wrap(status.encoders[i] - self.counts[i])) for i in (0, 1))
            if step > limit:
                return "encoders", (
                    f"encoder step of {step} counts in {dt:.2f} s, beyond the chair's top speed ({limit:.0f} at most)"
                )
        return "", ""

    def on_status(self, status: Status, now_s: float) -> tuple[str, str]:
        """A Status from the board: taken, or refused (:meth:`implausible`; returned)."""
        what, why = self.implausible(status, now_s)
        if what:
            if self.implausible_s is None:
                self.implausible_s = now_s
            if what == "encoders":  # the new counts are the baseline: the odometry does not jump
                self.odometry.forget()
                self.odometry.update(status.encoders)
                self.counts = status.encoders
            return what, why
        self.implausible_s = None
        self.counts = status.encoders
        self.status, self.status_s = status, now_s
        if status.flags & FLAG_ESTOP and not self.clear_pending and not self.estop:
            self.estop = True
            self.estop_source = "chair" if status.flags & FLAG_ESTOP_BOARD else "computer"
        if not status.flags & FLAG_ESTOP:
            self.clear_pending = False
        self.odometry.update(status.encoders)
        return "", ""

    def held(self, now_s: float) -> bool:
        """Whether implausible Status have gone on for :data:`HOLD_AFTER_S` (the chair is held)."""
        return self.implausible_s is not None and now_s - self.implausible_s >= HOLD_AFTER_S

    def on_line(self, ok: bool) -> None:
        """The line opened (True) or failed (False)."""
        if ok and not self.line_ok:
            self.odometry.forget()
            self.counts = None
        self.line_ok = ok

    def link_up(self, now_s: float) -> bool:
        """Whether the chair is heard."""
        return self.line_ok and now_s - self.status_s <= LINK_TIMEOUT_S

    def fresh(self, now_s: float) -> bool:
        """Whether the agent's command is fresh."""
        return now_s - self.action_s <= STALE_S

    def outgoing(self, now_s: float) -> Message:
        """What to send this cycle."""
        if self.estop:
            return EStop()
        if self.clear_pending:
            return Clear()
        if not self.fresh(now_s) or self.held(now_s):
            return Motors(0, 0)
        return Motors(power_to_units(self.command[0]), power_to_units(self.command[1]))

    def snapshot(self, now_s: float) -> Snapshot:
        """The chair now."""
        return Snapshot(self.odometry.pose, self.status, self.link_up(now_s), self.estop, self.estop_source)


def ranges_m(status: Status) -> tuple[list[int], list[float | None]]:
    """A Status's proximity ranges as sensor ids and metres (None: nothing in range)."""
    ids = list(range(len(status.ranges_mm)))
    return ids, [None if r == NO_RANGE else r / 1000 for r in status.ranges_mm]


def wheels(status: Status) -> tuple[float, float]:
    """The powers the motors run at."""
    return power_from_units(status.wheels[0]), power_from_units(status.wheels[1])


def watchdog(status: Status) -> bool:
    """Whether the board's watchdog holds the motors."""
    return bool(status.flags & FLAG_WATCHDOG)


def _wrap(d: int) -> int:
    """A difference of wrapping int32 counts."""
    return (d + 2**31) % 2**32 - 2**31
