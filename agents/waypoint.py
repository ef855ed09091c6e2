"""``iwz agent waypoint``: drives through waypoints from its GPS pose, avoiding obstacles its
proximity sensors see.

Steering: point at the next waypoint; when something is nearer than the safety distance ahead,
slow down and bias the heading towards the freer side. A waypoint counts as reached within the
tolerance; at the last one the chair stops and stays stopped.
"""

from __future__ import annotations

import argparse
import math

from iw_zenoh.agent import Command
from iw_zenoh.agent.places import points_arg, pose_arg
from iw_zenoh.core.motor import MAX_POWER
from iw_zenoh.core.revolving import Drum
from iw_zenoh.core.spec import NoiseSpec, RobotSpec, SensorNoise, prototype_chair, prototype_sensors
from iw_zenoh.messages import Heard, SensorReading
from iw_zenoh.scenario.specfile import spec_with_args

from .passage import parse_all
from .revolving import RevolvingPilot, mid_wheel_chair

__all__ = ["PROTOTYPE_SENSORS", "WaypointDriver", "add_arguments", "fine_chair", "make", "parse_revolving"]

STOP_M = 0.25  # stop when something is this near ahead
SIDE_M = 0.2  # keep this far off things beside
TURN_POWER = 0.04  # power difference at full turn
BACK_TICKS = 5  # after a collision, back off this many ticks
BACK_POWER = 0.05
PROTOTYPE_SENSORS = prototype_sensors(3.0)  # a 3 m sonar range for driving
FINE_GPS = SensorNoise(gps_m=NoiseSpec(0.0, 0.02), gps_heading_deg=NoiseSpec(0.0, 0.5))


def fine_chair(name: str, **kw: object) -> RobotSpec:
    """The LIACC prototype chair with 3 m sonars and a fine GPS (a localised chair)."""
    return prototype_chair(name, range_m=3.0, noise=FINE_GPS, **kw)


class WaypointDriver:
    """Follows waypoints with reactive obstacle avoidance.

    Args:
        spec: The robot.
        waypoints: (x, y) points in order, metres.
        tolerance_m: A waypoint is reached this near.
        safety_m: Avoid what is nearer than this ahead.
        speed: Cruise power in (0, 0.15].
    """

    def __init__(
        self,
        spec: RobotSpec,
        waypoints: list[tuple[float, float]],
        *,
        tolerance_m: float = 0.3,
        safety_m: float = 0.45,
        speed: float = 0.1,
    ) -> None:
        self._spec = spec
        self.waypoints = list(waypoints)
        self.tolerance_m = tolerance_m
        self.safety_m = safety_m
        self.speed = speed
        self.index = 0
        self.backing = 0
        self._angles = {s.id: s.angle_deg for s in spec.sensors}
        self._lateral = {s.id: s.y_m for s in spec.sensors}
        self.pilot: RevolvingPilot | None = None  # drives through a revolving door on the way

    def on_registered(self, robot_id: int, spec: RobotSpec) -> None:
        """Learns its id (a revolving door's protocol names chairs by robot id)."""
        if self.pilot is not None:
            self.pilot.on_registered(robot_id)

    def spec(self) -> RobotSpec:
        """The robot to register."""
        return self._spec

    @property
    def done(self) -> bool:
        """Whether the last waypoint was reached."""
        return self.index >= len(self.waypoints)

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """Steer to the next waypoint; slow and swerve for what is in the way; near a revolving
        door on the way, its pilot drives."""
        if self.pilot is None:
            return self._drive(reading)
        now_s = reading.sim_time_ns / 1e9
        if self.pilot.engaged(reading.gps[0], reading.gps[1]):
            return self.pilot.step(now_s, reading.gps, [m for h in heard for m in parse_all(h.text)])
        cmd = self._drive(reading)
        bye = self.pilot.farewell(now_s)
        return Command(cmd.left, cmd.right, say=bye) if bye else cmd

    def _drive(self, reading: SensorReading) -> Command:
        """Steer to the next waypoint; slow and swerve for what is in the way."""
        x, y, hdg = reading.gps
        while (
            not self.done
            and math.hypot(self.waypoints[self.index][0] - x, self.waypoints[self.index][1] - y) < self.tolerance_m
        ):
            self.index += 1
        if self.done:
            return Command(0.0, 0.0)
        if reading.collision:
            self.backing = BACK_TICKS
        if self.backing > 0:
            self.backing -= 1
            return Command(-BACK_POWER, -BACK_POWER)
        tx, ty = self.waypoints[self.index]
        err = math.remainder(math.degrees(math.atan2(ty - y, tx - x)) - hdg, 360.0)
        ahead_l = self._nearest(-35, 35, reading, side=1)
        ahead_r = self._nearest(-35, 35, reading, side=-1)
        ahead = min(ahead_l, ahead_r)
        left = self._nearest(35, 135, reading)
        right = self._nearest(-135, -35, reading)
        # cones are wide: a wall beside the path reads about half a metre when driving along it,
        # so brake between STOP and safety only, and swerve away from the nearer front corner
        speed = self.speed * min(1.0, max(0.0, (ahead - STOP_M) / (self.safety_m - STOP_M)))
        if ahead < self.safety_m and abs(err) < 15.0:
            err += -20.0 if ahead_l < ahead_r else 20.0
        if left < SIDE_M:
            err -= 10.0
        if right < SIDE_M:
            err += 10.0
        turn = max(-1.0, min(1.0, err / 30.0))
        if abs(err) > 20.0:
            speed = 0.0  # turn on the spot first
        left_p = speed - TURN_POWER * turn
        right_p = speed + TURN_POWER * turn
        return Command(max(-MAX_POWER, min(MAX_POWER, left_p)), max(-MAX_POWER, min(MAX_POWER, right_p)))

    def _nearest(self, lo: float, hi: float, reading: SensorReading, side: int = 0) -> float:
        """Nearest reading of the sensors looking between ``lo`` and ``hi`` degrees (and mounted
        on the left, side 1, or right, side -1, of the axis when asked)."""
        ds = [
            d
            for i, d in zip(reading.proximity_ids, reading.proximity_m, strict=True)
            if d is not None
            and lo <= self._angles.get(i, 0.0) <= hi
            and (side == 0 or (self._lateral.get(i, 0.0) >= 0.0) == (side > 0))
        ]
        return min(ds, default=math.inf)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``iwz agent waypoint``."""
    p.add_argument("--waypoints", required=True, type=points_arg, help="x,y;x,y;... in metres")
    p.add_argument("--robot-name", default="chair", help="robot name (default chair)")
    p.add_argument("--id", type=int, default=0, help="robot id to ask for (default: first free grid slot)")
    p.add_argument("--start", type=pose_arg, help="start pose x,y,dir_deg (default: the grid position of its id)")
    p.add_argument("--tolerance", type=float, default=0.3, help="a waypoint is reached this near, m (default 0.3)")
    p.add_argument(
        "--safety", type=float, default=0.45, help="slow down for what is nearer than this ahead, m (default 0.45)"
    )
    p.add_argument("--speed", type=float, default=0.1, help="cruise power, at most 0.15 (default 0.1)")
    p.add_argument(
        "--revolving-door",
        default="",
        metavar="ID,X,Y,AXIS[,RADIUS[,WINGS]]",
        help="a revolving door on the way: leaf 0's robot id, the hub, the passage's direction (deg), "
        "the drum's radius (default 1.6) and wings (default 3); the chair passes it one sector at a "
        "time (agents/revolving.py), e.g. --revolving-door 1,10,5,0",
    )
    p.add_argument(
        "--mid-wheel",
        action="store_true",
        help="a mid-wheel-drive chair (1.0 x 0.6, turns about its middle: it fits a revolving door's sector)",
    )


def make(args: argparse.Namespace) -> list[WaypointDriver]:
    """The agent the arguments ask for."""
    kw: dict[str, object] = {"id": args.id}
    if args.start is not None:
        x, y, d = args.start
        kw.update(x_m=x, y_m=y, dir_deg=d)
    chair = fine_chair(args.robot_name, **kw)
    spec = spec_with_args(mid_wheel_chair(chair) if args.mid_wheel else chair, args)
    driver = WaypointDriver(spec, args.waypoints, tolerance_m=args.tolerance, safety_m=args.safety, speed=args.speed)
    if args.revolving_door:
        door, drum = parse_revolving(args.revolving_door)
        driver.pilot = RevolvingPilot(drum, door, spec)
    return [driver]


def parse_revolving(text: str) -> tuple[int, Drum]:
    """Parses ``ID,X,Y,AXIS[,RADIUS[,WINGS]]``: a revolving door's id and geometry.

    Raises:
        ValueError: Saying what the form is.
    """
    parts = text.split(",")
    form = "--revolving-door is ID,X,Y,AXIS[,RADIUS[,WINGS]], e.g. 1,10,5,0"
    if not 4 <= len(parts) <= 6:
        raise ValueError(f"{form}; got {text!r}")
    try:
        door, wings = int(parts[0]), int(parts[5]) if len(parts) == 6 else 3
        x, y, axis = float(parts[1]), float(parts[2]), float(parts[3])
        radius = float(parts[4]) if len(parts) >= 5 else 1.6
    except ValueError:
        raise ValueError(f"{form}; got {text!r}") from None
    return door, Drum(x, y, axis_deg=axis, radius_m=radius, wings=wings)
