"""``iwz agent wheelchair``: the wheelchair control agent, driven by hand or on its own.

Autonomous (``--goal X,Y``): plans on the known map (``--map``) with A* over the chair's own
(x, y, heading) configuration space, follows the plan, maps what its cones see and plans again
when something blocks the way (see ``agents/autopilot.py``).

Manual (``--teleop``): the terminal is the joystick. Arrows drive (up/down forward and back,
left/right turn), space stops, + and - change the speed limit, q quits. A key held down repeats;
when no key has come for ``--stale`` seconds the chair stops. A status line shows the speed limit
and the nearest reading of each sensor.

Doors (``--door ID,X,Y``): a negotiated door on the way. Within 4 m the chair asks it for
passage over the radio (``agents/passage.py``), and without a grant it stops 2.3 m from it.

Chairs (``--chair``): ``simulated`` (virtual sensors only, the world moves the chair); ``augmented`` and ``real``
drive a real chair that reports its own pose (odometry) to the world as a Real robot.
``--hardware serial --id N`` drives the chair that ``iwz bridge serial`` registered as robot N
(the bridge reports its pose and its own readings; see ``docs/serial.md``); ``--hardware
emulated`` stands in a chair emulated in-process on the core, in a room of its own (``--room``,
the real obstacles), whose encoders slip so its odometry drifts. In ``augmented`` mode the
virtual readings (at the reported pose) and the chair's own are merged conservatively: for each
sensor the nearer reading wins. In ``real`` mode only the chair's own readings are used.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
from dataclasses import dataclass, replace

from iw_zenoh.agent import Command
from iw_zenoh.agent.places import parse_boxes, point_arg, pose_arg
from iw_zenoh.core.lab import Lab
from iw_zenoh.core.motor import MAX_POWER
from iw_zenoh.core.spec import RobotSpec, RobotType, SensorNoise
from iw_zenoh.maps import load_lab
from iw_zenoh.messages import ChairReading, Heard, SensorReading
from iw_zenoh.scenario.specfile import spec_with_args

from .autopilot import Autopilot, mapping_chair
from .chairlink import SerialChair
from .emulated import EmulatedChair
from .passage import Client, parse_all
from .teleop import Teleop, terminal_teleop
from .waypoint import FINE_GPS

__all__ = ["Wheelchair", "add_arguments", "make", "merge_nearer"]

logger = logging.getLogger(__name__)

ASK_M = 4.0  # ask a door on the way for passage from this far
WAIT_M = 2.3  # without a grant, stop this far from the door (its leaf swings 1 m)
NEAR_M = 0.8  # in the doorway
DOORWAY_R = 0.6  # the closed leaf lies within this of the doorway's middle: not an obstacle to map
HYSTERESIS_M = 0.4  # once waiting, wait until granted or this much farther than WAIT_M
THROUGH_M = 1.5  # this far again after the doorway: through


@dataclass
class Gate:
    """A negotiated door on the chair's way: where it is and the protocol's chair side."""

    client: Client
    x: float
    y: float
    near: bool = False
    waiting: bool = False
    wanted: bool = False  # asked and not through yet: keep asking while near, plan or no plan


def merge_nearer(a: list[float | None], b: list[float | None]) -> list[float | None]:
    """Per sensor, the nearer of two readings (None: nothing in range)."""
    out: list[float | None] = []
    for x, y in zip(a, b, strict=True):
        out.append(y if x is None else x if y is None else min(x, y))
    return out


class Wheelchair:
    """The wheelchair agent.

    Args:
        spec: The chair to register.
        known: The map it plans on (autonomous).
        goal: Where to go (autonomous), or None with ``teleop``.
        mode: simulated, augmented or real.
        hardware: The real chair (augmented and real modes).
        teleop: Manual control.
    """

    def __init__(
        self,
        spec: RobotSpec,
        known: Lab,
        *,
        goal: tuple[float, float] | None,
        mode: str = "simulated",
        hardware: EmulatedChair | SerialChair | None = None,
        teleop: Teleop | None = None,
        doors: list[tuple[int, float, float]] | None = None,
        careful: bool = False,
    ) -> None:
        self._spec = spec
        self.mode = mode
        self.hardware = hardware
        self.teleop = teleop
        self.pilot = Autopilot(
            spec,
            known,
            movers=[(x, y, DOORWAY_R) for _, x, y in doors or []],
            careful=careful,
            margin_m=0.05 if careful else 0.04,
        )
        if goal is not None:
            self.pilot.set_goal(goal)
        self.status = ""
        self._last_status = ""
        self.doors = doors or []
        self.gates: list[Gate] = []
        # a chair on a serial link: drive the robot its bridge registered (nodes/agents.py attaches)
        self.attach_to = spec.id if isinstance(hardware, SerialChair) else 0

    def on_chair(self, msg: ChairReading) -> None:
        """The serial bridge's readings of the chair."""
        if isinstance(self.hardware, SerialChair):
            self.hardware.update(msg)

    def on_registered(self, robot_id: int, spec: RobotSpec) -> None:
        """Learns its id (the passage protocol names chairs by robot id)."""
        self.gates = [Gate(Client(d, robot_id), x, y) for d, x, y in self.doors]

    def _negotiate(
        self, pose: tuple[float, float, float], heard: list[Heard], now_s: float
    ) -> tuple[str | None, int | None]:
        """Talks to the doors on the way; returns (what to say, the door to wait for or None)."""
        msgs = [m for h in heard for m in parse_all(h.text)]
        say: str | None = None
        wait_for: int | None = None
        for g in self.gates:
            g.client.hear(msgs, now_s)
            d = math.hypot(g.x - pose[0], g.y - pose[1])
            if d < NEAR_M:
                g.near = True
            through = g.near and d > THROUGH_M
            if through:
                g.near = False
            # once it has asked, a chair keeps asking until it is through (or has gone away): a
            # chair that stops to plan again has no path for a moment, and falling silent then
            # lost it the doorway while it stood in the leaf's way
            wants = d < ASK_M and (g.near or g.wanted or self.pilot.passes_near(g.x, g.y, 1.0)) and not through
            g.wanted = wants
            text = g.client.say(now_s, wants=wants, eta_s=d / 0.2, through=through)
            say = say or text
            limit = WAIT_M + (HYSTERESIS_M if g.waiting else 0.0)
            g.waiting = wants and not g.near and d < limit and not g.client.granted(now_s)
            if g.waiting:
                wait_for = g.client.door
        return say, wait_for

    def spec(self) -> RobotSpec:
        """The chair to register (a Real robot when a real chair drives)."""
        return self._spec

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """This tick: sense (merged as the mode says), decide, drive."""
        dists: list[float | None] = list(reading.proximity_m)
        pose = reading.gps
        hw = self.hardware
        if hw is not None:
            own = hw.reading if isinstance(hw, EmulatedChair) else hw.taken_at(reading.gps)
            own_by_id = dict(zip(own.proximity_ids, own.proximity_m, strict=True))
            mine = [own_by_id.get(i) for i in reading.proximity_ids]
            dists = mine if self.mode == "real" else merge_nearer(dists, mine)
            # on a serial link the virtual readings were taken where the world placed the chair
            # (its exact GPS: the bridge's last pose report), the one pose both readings share
            pose = hw.pose if isinstance(hw, EmulatedChair) else reading.gps
        collided = reading.collision or (hw is not None and hw.reading.collision)
        say: str | None = None
        if self.teleop is not None:
            left, right, self.status = self.teleop.command(time.monotonic())
            near = " ".join("-" if d is None else f"{d:.2f}" for d in dists)
            print(
                f"\r{self.status:8} limit {self.teleop.limit:.2f}  sensors {near}   ",
                end="",
                file=sys.stderr,
                flush=True,
            )
        else:
            say, wait_for = self._negotiate(pose, heard, reading.sim_time_ns / 1e9) if self.gates else (None, None)
            if wait_for is not None:
                left, right, self.status = 0.0, 0.0, f"waiting for door {wait_for}"
            else:
                d = self.pilot.step(pose, list(reading.proximity_ids), dists, collided=collided)
                scale = MAX_POWER / self._spec.max_speed_mps
                left, right, self.status = d.left_mps * scale, d.right_mps * scale, d.status
        if self.status != self._last_status:
            logger.info("t=%.1f s at (%.2f, %.2f): %s", reading.sim_time_ns / 1e9, pose[0], pose[1], self.status)
            self._last_status = self.status
        if isinstance(hw, EmulatedChair):
            hw.drive(left, right)
            return Command(0.0, 0.0, pose=hw.pose, say=say)
        return Command(left, right, say=say)  # on a serial link the bridge reports the pose


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``iwz agent wheelchair``."""
    p.add_argument("--map", required=True, help="the map the chair knows (Lab XML); obstacles not in it are found")
    p.add_argument("--start", required=True, type=pose_arg, help="start pose x,y,dir_deg")
    p.add_argument("--goal", type=point_arg, help="autonomous: drive to x,y")
    p.add_argument("--teleop", action="store_true", help="manual: drive with the arrow keys in this terminal")
    p.add_argument(
        "--stale", type=float, default=0.5, help="teleop: stop when no key came for this long, s (default 0.5)"
    )
    p.add_argument(
        "--limit", type=float, default=0.06, help="teleop: speed limit as motor power (default 0.06, max 0.15)"
    )
    p.add_argument(
        "--chair",
        choices=["simulated", "augmented", "real"],
        default="simulated",
        help="simulated (virtual sensors), augmented (a real chair, its sensors merged with the virtual ones) "
        "or real (a real chair, its own sensors); default simulated",
    )
    p.add_argument(
        "--hardware",
        choices=["emulated", "serial"],
        default="emulated",
        help="the real chair (augmented/real modes): emulated in-process, or the robot --id that "
        "`iwz bridge serial` registered",
    )
    p.add_argument("--room", default="", help="emulated hardware: its real room's obstacles x0,y0,x1,y1;... on --map")
    p.add_argument(
        "--door",
        action="append",
        default=[],
        metavar="ID,X,Y",
        help="a negotiated door on the way: its robot id and the middle of its doorway (repeat for more)",
    )
    p.add_argument(
        "--careful",
        action="store_true",
        help="tight floors (1.1 m doorways): 5 cm margin, slow near things, no corrective turns on the spot",
    )
    p.add_argument("--id", type=int, default=0, help="robot id to ask for")
    p.add_argument("--robot-name", default="wheelchair", help="robot name")
    p.add_argument("--seed", type=int, default=0, help="emulated hardware noise seed")


def make(args: argparse.Namespace) -> list[Wheelchair]:
    """The chair the arguments ask for."""
    if not args.teleop and args.goal is None:
        raise ValueError("say where to go (--goal X,Y) or drive by hand (--teleop)")
    if not 0.0 < args.limit <= MAX_POWER:
        raise ValueError(f"--limit must be in (0, {MAX_POWER}], got {args.limit}")
    x, y, d = args.start
    known = load_lab(args.map)
    spec = spec_with_args(mapping_chair(args.robot_name, id=args.id, x_m=x, y_m=y, dir_deg=d, noise=FINE_GPS), args)
    hardware: EmulatedChair | SerialChair | None = None
    if args.chair != "simulated" and args.hardware == "serial":
        if args.id <= 0:
            raise ValueError("--hardware serial drives the robot its bridge registered: give its --id")
        hardware = SerialChair((x, y, d))
        spec = replace(spec, type=RobotType.REAL, noise=SensorNoise())
    elif args.chair != "simulated":
        hardware = EmulatedChair(spec, known.with_walls(parse_boxes(args.room)), seed=args.seed)
        spec = replace(spec, type=RobotType.REAL, noise=SensorNoise())
    teleop = terminal_teleop(limit=args.limit, stale_s=args.stale) if args.teleop else None
    goal = args.goal
    doors = []
    for text in args.door:
        parts = text.split(",")
        if len(parts) != 3:
            raise ValueError(f"--door is ID,X,Y, got {text!r}")
        doors.append((int(parts[0]), float(parts[1]), float(parts[2])))
    return [
        Wheelchair(
            spec, known, goal=goal, mode=args.chair, hardware=hardware, teleop=teleop, doors=doors, careful=args.careful
        )
    ]
