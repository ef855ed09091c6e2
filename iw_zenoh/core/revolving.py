"""A revolving door's geometry and the motions of its passage, pure.

The door: ``wings`` leaves (Door robots, each a rectangle from the hub outwards, turning about
the hub) in a drum of radius ``radius_m`` centred on the hub; the drum's walls (map walls,
:func:`drum_walls`) leave two openings of ``360 / wings`` degrees facing along the passage's
axis. Leaf ``k`` points at ``axis_deg + k * 360 / wings + turn`` (``turn`` is the door's rotation,
counter-clockwise, from where it started): at ``turn`` = 0 (mod the sector) a sector faces a chair
coming along the axis (side ``+1``), half a sector further one faces a chair coming against it
(side ``-1``).

The passage, one sector and one chair at a time: the door turns so a sector faces the chair; the
chair drives along the axis into the sector until its centre is ``ring_m`` from the hub, turns on
the spot to face the way the door turns (the tangent of the ring); the door turns half a circle,
counter-clockwise, along a smooth profile (:func:`profile`) while the chair rides the ring
beside it (:func:`ride_pose`, followed by :func:`track`); the chair turns back to the axis and
drives out. A chair that turns on the spot in its sector needs a sector wider than its turning
circle: a mid-wheel-drive chair (:data:`MID_WHEEL`, centre of movement in the middle) in a
3-wing door of radius 1.6 m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from iw_zenoh.core.motor import MAX_POWER

__all__ = [
    "LEAF_GAP_M",
    "MID_WHEEL",
    "Drum",
    "drum_walls",
    "profile",
    "ride_pose",
    "to_powers",
    "track",
    "travel_deg",
    "turn_rate",
]

LEAF_GAP_M = 0.05  # between a leaf's tip and the drum wall
MID_WHEEL = {"width_m": 1.0, "height_m": 0.6, "com": 0.5}  # a mid-wheel-drive chair turns about its middle


@dataclass(frozen=True)
class Drum:
    """A revolving door's geometry.

    Attributes:
        hub_x: The hub's x, m.
        hub_y: The hub's y, m.
        axis_deg: The passage's direction (side +1 travels along it), degrees.
        radius_m: The drum's inside radius, m.
        wings: Leaves (3 or 4).
        ring_m: How far from the hub a carried chair's centre rides, m.
    """

    hub_x: float
    hub_y: float
    axis_deg: float = 0.0
    radius_m: float = 1.6
    wings: int = 3
    ring_m: float = 0.9

    def __post_init__(self) -> None:
        if not 3 <= self.wings <= 4:
            raise ValueError(
                f"a revolving door here has 3 or 4 wings (its openings span 180 - 360/wings), got {self.wings}"
            )
        if not 0.0 < self.ring_m < self.radius_m:
            raise ValueError(
                f"the ring a carried chair rides ({self.ring_m:g} m from the hub) must lie inside the drum "
                f"(radius {self.radius_m:g} m): give a larger radius (1.6 m fits a mid-wheel chair)"
            )

    @property
    def sector_deg(self) -> float:
        """The angle between two leaves."""
        return 360.0 / self.wings

    @property
    def leaf_m(self) -> float:
        """A leaf's length, from the hub to just short of the drum."""
        return self.radius_m - LEAF_GAP_M

    def leaf_heading_deg(self, k: int, turn_deg: float) -> float:
        """Where leaf ``k`` points when the door has turned ``turn_deg``."""
        return self.axis_deg + k * self.sector_deg + turn_deg

    def facing_turn_deg(self, side: int) -> float:
        """A turn (mod one sector) at which a sector faces a chair coming from ``side``."""
        return 0.0 if side > 0 else 0.5 * self.sector_deg

    def faces(self, turn_deg: float, side: int) -> bool:
        """Whether a sector faces a chair coming from ``side`` at this turn."""
        off = math.remainder(turn_deg - self.facing_turn_deg(side), self.sector_deg)
        return abs(off) < 0.5

    def point(self, along_m: float, side: int) -> tuple[float, float]:
        """The point ``along_m`` along the axis from the hub, in the direction a chair from ``side``
        travels (negative: before the hub)."""
        a = math.radians(self.axis_deg if side > 0 else self.axis_deg + 180.0)
        return self.hub_x + along_m * math.cos(a), self.hub_y + along_m * math.sin(a)

    def side_of(self, x: float, y: float) -> int:
        """The side a chair at (x, y) comes from: +1 when it is behind the hub along the axis."""
        a = math.radians(self.axis_deg)
        return 1 if (x - self.hub_x) * math.cos(a) + (y - self.hub_y) * math.sin(a) < 0.0 else -1


def travel_deg(drum: Drum, side: int) -> float:
    """The heading of a chair passing from ``side``."""
    return drum.axis_deg if side > 0 else drum.axis_deg + 180.0


def ride_pose(drum: Drum, side: int, done_deg: float) -> tuple[float, float, float]:
    """Where a chair carried from ``side`` rides when the door has turned ``done_deg`` of its half
    turn: (x m, y m, heading deg), on the ring, facing the way the door turns."""
    polar = math.radians(travel_deg(drum, side) + 180.0 + done_deg)
    x = drum.hub_x + drum.ring_m * math.cos(polar)
    y = drum.hub_y + drum.ring_m * math.sin(polar)
    return x, y, math.degrees(polar) + 90.0


def profile(elapsed_s: float, span_deg: float, duration_s: float) -> tuple[float, float]:
    """A smooth turn of ``span_deg`` in ``duration_s``: (turned so far deg, rate deg/s) after
    ``elapsed_s`` (half a cosine: it starts and ends at rest)."""
    tau = min(1.0, max(0.0, elapsed_s / duration_s))
    done = span_deg * 0.5 * (1.0 - math.cos(math.pi * tau))
    rate = span_deg * 0.5 * math.pi / duration_s * math.sin(math.pi * tau) if tau < 1.0 else 0.0
    return done, rate


def turn_rate(heading_deg: float, target_deg: float, *, gain: float = 1.5, most: float = 0.6) -> float:
    """A turn on the spot towards ``target_deg``: the rate (rad/s) to command."""
    err = math.radians(math.remainder(target_deg - heading_deg, 360.0))
    return max(-most, min(most, gain * err))


def track(
    pose: tuple[float, float, float], target: tuple[float, float, float], v_ref: float, w_ref: float
) -> tuple[float, float]:
    """Follows a moving pose (Kanayama's tracking law): (v m/s, w rad/s) to command.

    Args:
        pose: The chair (x m, y m, heading deg).
        target: Where it should be (x m, y m, heading deg).
        v_ref: The target's speed, m/s.
        w_ref: The target's turn rate, rad/s.
    """
    h = math.radians(pose[2])
    dx, dy = target[0] - pose[0], target[1] - pose[1]
    ex = math.cos(h) * dx + math.sin(h) * dy
    ey = -math.sin(h) * dx + math.cos(h) * dy
    eh = math.radians(math.remainder(target[2] - pose[2], 360.0))
    v = v_ref * math.cos(eh) + 1.5 * ex
    w = w_ref + 4.0 * ey + 2.0 * math.sin(eh)
    return v, w


def to_powers(v_mps: float, w_rps: float, *, wheel_base_m: float, max_speed_mps: float) -> tuple[float, float]:
    """Motor powers (left, right) for a speed and a turn rate, within the power limit."""
    scale = MAX_POWER / max_speed_mps
    left = (v_mps - 0.5 * w_rps * wheel_base_m) * scale
    right = (v_mps + 0.5 * w_rps * wheel_base_m) * scale
    return max(-MAX_POWER, min(MAX_POWER, left)), max(-MAX_POWER, min(MAX_POWER, right))


def drum_walls(drum: Drum, *, thick_m: float = 0.1, step_deg: float = 5.0) -> list[list[tuple[float, float]]]:
    """The drum's two walls as polygons (corners counter-clockwise): arcs of one sector each,
    across the axis, outside ``radius_m`` (a chord of an arc never comes inside it)."""
    inner = drum.radius_m / math.cos(math.radians(0.5 * step_deg))
    walls = []
    for mid in (drum.axis_deg + 90.0, drum.axis_deg - 90.0):
        lo, hi = mid - 0.5 * drum.sector_deg, mid + 0.5 * drum.sector_deg
        n = max(1, math.ceil((hi - lo) / step_deg))
        angles = [math.radians(lo + (hi - lo) * i / n) for i in range(n + 1)]
        out = [
            (drum.hub_x + (inner + thick_m) * math.cos(a), drum.hub_y + (inner + thick_m) * math.sin(a)) for a in angles
        ]
        into = [(drum.hub_x + inner * math.cos(a), drum.hub_y + inner * math.sin(a)) for a in reversed(angles)]
        walls.append(out + into)
    return walls
