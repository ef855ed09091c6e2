"""``iwz agent convoy``: follow the leader (the hospital paper's demo).

Every chair of the convoy says where it is each tick, over the radio (range-limited, 100 bytes):
``P <id> <x> <y>``. The leader drives its waypoints; each follower keeps a gap behind the chair
it follows, heard over the radio, slowing as the gap closes and stopping for what is in its way.
A follower that hears nothing from its leader stops.
"""

from __future__ import annotations

import argparse
import math

from iw_zenoh.agent import Command
from iw_zenoh.agent.places import points_arg
from iw_zenoh.core.motor import MAX_POWER
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import Heard, SensorReading
from iw_zenoh.scenario.specfile import spec_with_args

from .waypoint import WaypointDriver, fine_chair

__all__ = ["Follower", "Leader", "add_arguments", "make", "parse_position"]

STALE_TICKS = 10  # a leader unheard this long: stop
CATCH_UP_M = 0.5  # full speed once the gap is this much too long


def say_position(robot_id: int, x: float, y: float) -> str:
    """The convoy's one message: ``P id x y`` (well under 100 bytes)."""
    return f"P {robot_id} {x:.2f} {y:.2f}"


def parse_position(text: str) -> tuple[int, float, float] | None:
    """``(id, x, y)`` of a position message, or None for anything else."""
    parts = text.split()
    if len(parts) != 4 or parts[0] != "P":
        return None
    try:
        return int(parts[1]), float(parts[2]), float(parts[3])
    except ValueError:
        return None


class Leader(WaypointDriver):
    """Drives its waypoints and says where it is."""

    def __init__(self, spec: RobotSpec, waypoints: list[tuple[float, float]], **kw: float) -> None:
        super().__init__(spec, waypoints, **kw)
        self.robot_id = 0

    def on_registered(self, robot_id: int, spec: RobotSpec) -> None:
        """Learns its id."""
        self.robot_id = robot_id

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """Drive, and say where."""
        cmd = super().on_sensors(reading, heard)
        return Command(cmd.left, cmd.right, say=say_position(self.robot_id, reading.gps[0], reading.gps[1]))


class Follower:
    """Keeps ``gap_m`` behind the chair ``follow_id``.

    Args:
        spec: The chair.
        follow_id: The robot it follows.
        gap_m: Centre-to-centre distance to keep.
        speed: Cruise power.
    """

    def __init__(self, spec: RobotSpec, follow_id: int, *, gap_m: float = 2.0, speed: float = 0.15) -> None:
        self._spec = spec
        self.follow_id = follow_id
        self.gap_m = gap_m
        self.speed = speed
        self.robot_id = 0
        self.target: tuple[float, float] | None = None
        self.unheard = 0
        self._front = {s.id for s in spec.sensors if abs(s.angle_deg) < 35}

    def spec(self) -> RobotSpec:
        """The chair to register."""
        return self._spec

    def on_registered(self, robot_id: int, spec: RobotSpec) -> None:
        """Learns its id."""
        self.robot_id = robot_id

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """Close the gap to the chair ahead, no nearer than the gap."""
        x, y, hdg = reading.gps
        self.unheard += 1
        for h in heard:
            pos = parse_position(h.text)
            if pos is not None and pos[0] == self.follow_id:
                self.target, self.unheard = (pos[1], pos[2]), 0
        me = say_position(self.robot_id, x, y)
        if self.target is None or self.unheard > STALE_TICKS:
            return Command(0.0, 0.0, say=me)
        tx, ty = self.target
        dist = math.hypot(tx - x, ty - y)
        err = math.remainder(math.degrees(math.atan2(ty - y, tx - x)) - hdg, 360.0)
        ahead = min(
            (
                d
                for i, d in zip(reading.proximity_ids, reading.proximity_m, strict=True)
                if d is not None and i in self._front
            ),
            default=math.inf,
        )
        speed = self.speed * max(0.0, min(1.0, (dist - self.gap_m) / CATCH_UP_M))
        if ahead < 0.35:
            speed = 0.0
        turn = max(-1.0, min(1.0, err / 30.0))
        if abs(err) > 30.0:
            speed = 0.0
        left = max(-MAX_POWER, min(MAX_POWER, speed - 0.04 * turn))
        right = max(-MAX_POWER, min(MAX_POWER, speed + 0.04 * turn))
        return Command(left, right, say=me)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``iwz agent convoy``."""
    p.add_argument(
        "--role", choices=["leader", "follower"], required=True, help="lead (waypoints) or follow (a robot id)"
    )
    p.add_argument("--id", type=int, default=0, help="robot id to ask for")
    p.add_argument("--robot-name", default="", help="robot name (default leader / followerN)")
    p.add_argument("--waypoints", type=points_arg, help="leader: x,y;x,y;... in metres")
    p.add_argument("--follow", type=int, default=0, help="follower: the robot id it follows")
    p.add_argument("--gap", type=float, default=2.0, help="follower: centre-to-centre gap to keep, m (default 2)")


def make(args: argparse.Namespace) -> list[Leader | Follower]:
    """The convoy member the arguments ask for."""
    if args.role == "leader":
        spec = spec_with_args(fine_chair(args.robot_name or "leader", id=args.id), args)
        if not args.waypoints:
            raise ValueError("a leader needs --waypoints x,y;x,y;... (e.g. --waypoints '20,6.1')")
        return [Leader(spec, args.waypoints, speed=0.08)]
    if args.follow <= 0:
        raise ValueError("a follower needs --follow ID")
    spec = spec_with_args(fine_chair(args.robot_name or f"follower{args.id}", id=args.id), args)
    return [Follower(spec, args.follow, gap_m=args.gap)]
