"""``iwz agent door``: doors as robots moved by their own agent (hinged, sliding, revolving).

The state machine of the seed's Fig. 5.5: Closed -> (something detected) -> Opening -> (turned
90 degrees, or slid its length) -> Open (timer starts) -> (timeout with nothing detected) ->
Closing -> (back where it was) -> Closed. While opening or closing a collision stops the
movement and it resumes when the collision clears; something detected while closing opens the
door again (nobody gets shut in). (The machine's revolving kind, a single leaf turning while
something is detected, is the seed's; it let no chair through a doorway, and ``--kind revolving``
no longer runs it.)

A sliding door's leaf lies along its heading and slides its whole length forward into the wall
beside the doorway (door bodies pass through walls), so the doorway is clear when it is open. A
revolving door (``--kind revolving``) is not this machine: its leaves and the passage of a chair,
one sector at a time, are ``agents/revolving.py`` (it always negotiates, over the radio).

Two policies for hinged and sliding doors: ``proximity`` opens when a door sensor detects something (the seed's test);
``negotiate`` opens for the chairs that ask over the radio and grants the doorway to one at a
time (``agents/passage.py`` has the protocol). Under either, a closing door that detects
something opens again.
"""

from __future__ import annotations

import argparse
import enum
import math
from dataclasses import dataclass, replace

from iw_zenoh.agent import Command
from iw_zenoh.agent.places import pose_arg
from iw_zenoh.core.revolving import Drum
from iw_zenoh.core.spec import IrSensorSpec, NoiseSpec, RobotSpec, RobotType, SensorNoise
from iw_zenoh.messages import Heard, SensorReading

from .passage import Arbiter, join, parse_all
from .revolving import LeafAgent, leaves

__all__ = ["DoorKind", "DoorMachine", "DoorParams", "DoorState", "add_arguments", "door_spec", "make"]

DOOR_CURVE = 0.1  # a door's drive answers almost at once, so it stops where it is told
SLOW_SHARE = 0.2  # the slowest a door moves near the end of its travel, as a share of its power
EXACT = SensorNoise(*(NoiseSpec(0.0, 0.0, enabled=False),) * 8)
LEAF_M = 1.0  # the seed's door leaf
SLIDING_THICK_M = 0.08  # a sliding leaf is thinner than the 0.1 m walls, so it hides in its pocket
SENSOR_OFF_M = 0.2  # a sliding door's sensors stand this far out from the wall's faces


class DoorKind(enum.StrEnum):
    """The seed's three doors (section 5.3)."""

    HINGED = "hinged"
    SLIDING = "sliding"
    REVOLVING = "revolving"


class DoorState(enum.StrEnum):
    """Fig. 5.5."""

    CLOSED = "closed"
    OPENING = "opening"
    OPEN = "open"
    CLOSING = "closing"


@dataclass(frozen=True)
class DoorParams:
    """How a door behaves.

    Attributes:
        kind: Hinged, sliding or revolving.
        detect_m: Something nearer than this to a door sensor is detected.
        open_deg: How far a hinged door turns (degrees).
        slide_m: How far a sliding door slides.
        timeout_s: Open this long with nothing detected, then close.
        power: Motor power while moving.
    """

    kind: DoorKind = DoorKind.HINGED
    detect_m: float = 1.0
    open_deg: float = 90.0
    slide_m: float = 1.0
    timeout_s: float = 3.0
    power: float = 0.05


class DoorMachine:
    """The state machine, pure: readings in, motor command out.

    Args:
        params: Behaviour.
        closed_pose: (x, y, heading deg) of the closed door.
    """

    def __init__(self, params: DoorParams, closed_pose: tuple[float, float, float]) -> None:
        self.p = params
        self.closed = closed_pose
        self.state = DoorState.CLOSED
        self.timer_s = 0.0

    def progress(self, pose: tuple[float, float, float]) -> float:
        """0 when closed, 1 when fully open."""
        x, y, h = pose
        if self.p.kind == DoorKind.SLIDING:
            return math.hypot(x - self.closed[0], y - self.closed[1]) / self.p.slide_m
        return abs(math.remainder(h - self.closed[2], 360.0)) / self.p.open_deg

    def step(
        self, *, detected: bool, collided: bool, pose: tuple[float, float, float], dt_s: float
    ) -> tuple[float, float]:
        """Advances one tick; returns (left, right) motor powers."""
        p = self.p
        if p.kind == DoorKind.REVOLVING:
            if detected:
                self.state, self.timer_s = DoorState.OPENING, 0.0
            elif self.state != DoorState.CLOSED:
                self.timer_s += dt_s
                if self.timer_s >= p.timeout_s:
                    self.state = DoorState.CLOSED
            turning = self.state == DoorState.OPENING and not collided
            return (-p.power, p.power) if turning else (0.0, 0.0)
        done = self.progress(pose)
        if self.state == DoorState.CLOSED and detected:
            self.state = DoorState.OPENING
        elif self.state == DoorState.OPENING and done >= 1.0:
            self.state, self.timer_s = DoorState.OPEN, 0.0
        elif self.state == DoorState.OPEN:
            self.timer_s = 0.0 if detected else self.timer_s + dt_s
            if self.timer_s >= p.timeout_s:
                self.state = DoorState.CLOSING
        elif self.state == DoorState.CLOSING:
            if detected:
                self.state = DoorState.OPENING  # never shut on someone
            elif done <= 0.02:
                self.state = DoorState.CLOSED
        if collided or self.state in (DoorState.CLOSED, DoorState.OPEN):
            return 0.0, 0.0  # a collision stops the movement; it resumes when clear
        sign = 1.0 if self.state == DoorState.OPENING else -1.0
        left = 1.0 - done if sign > 0 else done
        power = p.power * min(1.0, max(SLOW_SHARE, 2.0 * left))  # ease in, so inertia does not overshoot
        if p.kind == DoorKind.SLIDING:
            return sign * power, sign * power
        return -sign * power, sign * power


def door_spec(
    name: str,
    kind: DoorKind,
    *,
    x: float,
    y: float,
    dir_deg: float,
    test_door: bool = False,
    leaf_m: float = LEAF_M,
) -> RobotSpec:
    """A door body.

    Hinged and revolving: the seed's table (leaf ``leaf_m`` across, 0.1 thick; COM 0.99, revolving
    0.5), or the test door of section 7.4 (1.0 long, 0.1 across, COM 0.99, sensors at +-90 deg,
    cone 40). Sliding: a leaf ``leaf_m`` long ALONG its heading, thinner than a wall, at (x, y) when
    closed; it slides forward its whole length into the wall beside the doorway (its pocket: door
    bodies pass through walls), so an open doorway is clear.
    """
    if kind == DoorKind.SLIDING:
        return _sliding_spec(name, x=x, y=y, dir_deg=dir_deg, leaf_m=leaf_m)
    if test_door:
        # at the middle of the leaf, so that open, they look past the door frame, not at it
        sensors = (IrSensorSpec(0, 0.5, 0.05, 90.0, 40.0, 3.0), IrSensorSpec(1, 0.5, -0.05, -90.0, 40.0, 3.0))
        return _door_body(name, (x, y, dir_deg), 1.0, 0.1, 0.99, sensors)
    com = 0.5 if kind == DoorKind.REVOLVING else 0.99
    sensors = (IrSensorSpec(0, 0.05, 0.0, 0.0, 60.0, 3.0), IrSensorSpec(1, -0.05, 0.0, 180.0, 60.0, 3.0))
    return _door_body(name, (x, y, dir_deg), 0.1, leaf_m, com, sensors)


def _sliding_spec(name: str, *, x: float, y: float, dir_deg: float, leaf_m: float) -> RobotSpec:
    """A sliding leaf along its heading. Its two sensors sit at its trailing end, which stays at the
    doorway's edge when open, on brackets SENSOR_OFF_M out from the wall's faces (inside a wall a
    cone would read the wall), looking out of either face: they see a chair coming, closed or open."""
    rear = -0.5 * leaf_m
    sensors = (
        IrSensorSpec(0, rear, SENSOR_OFF_M, 90.0, 60.0, 3.0),
        IrSensorSpec(1, rear, -SENSOR_OFF_M, -90.0, 60.0, 3.0),
    )
    return _door_body(name, (x, y, dir_deg), leaf_m, SLIDING_THICK_M, 0.5, sensors)


def _door_body(
    name: str,
    at: tuple[float, float, float],
    width_m: float,
    height_m: float,
    com: float,
    sensors: tuple[IrSensorSpec, ...],
) -> RobotSpec:
    """What every door body shares: exact sensors, 0.5 m/s at most, the doors' acceleration curve."""
    x, y, dir_deg = at
    return RobotSpec(
        name,
        type=RobotType.DOOR,
        width_m=width_m,
        height_m=height_m,
        com=com,
        x_m=x,
        y_m=y,
        dir_deg=dir_deg,
        ir_sensors=sensors,
        noise=EXACT,
        max_speed_mps=0.5,
        acceleration_curve=DOOR_CURVE,
    )


class DoorAgent:
    """A door driven by its state machine from its own sensors, or by negotiation.

    Args:
        spec: The door body.
        params: Behaviour.
        dt_s: Tick length.
        negotiate: Open for chairs that ask over the radio (else on proximity).
    """

    def __init__(self, spec: RobotSpec, params: DoorParams, dt_s: float = 0.1, *, negotiate: bool = False) -> None:
        self._spec = spec
        self.machine = DoorMachine(params, (spec.x_m or 0.0, spec.y_m or 0.0, spec.dir_deg or 0.0))
        self.dt_s = dt_s
        self.arbiter: Arbiter | None = None
        self.negotiate = negotiate
        self._outbox: list[str] = []

    def on_registered(self, robot_id: int, spec: RobotSpec) -> None:
        """Learns its id (the protocol names doors by robot id)."""
        if self.negotiate:
            self.arbiter = Arbiter(robot_id)

    def spec(self) -> RobotSpec:
        """The door to register."""
        return self._spec

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """One tick of the state machine."""
        near = [d for d in reading.proximity_m if d is not None]
        detected = bool(near) and min(near) < self.machine.p.detect_m
        say = None
        if self.arbiter is not None:
            msgs = [m for h in heard for m in parse_all(h.text)]
            is_open = self.machine.state == DoorState.OPEN
            answers = self.arbiter.step(msgs, reading.sim_time_ns / 1e9, is_open)
            say, self._outbox = join(self._outbox + [a.text() for a in answers])
            # open for the chairs that want it; a closing door still reopens for what it detects
            detected = self.arbiter.wanted or (detected and self.machine.state == DoorState.CLOSING)
        left, right = self.machine.step(detected=detected, collided=reading.collision, pose=reading.gps, dt_s=self.dt_s)
        return Command(left, right, say=say)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``iwz agent door``."""
    p.add_argument("--kind", choices=[k.value for k in DoorKind], default="hinged", help="door kind (default hinged)")
    p.add_argument(
        "--at",
        required=True,
        type=pose_arg,
        help="closed pose x,y,dir_deg (revolving: its hub and the passage's direction)",
    )
    p.add_argument("--robot-name", default="door", help="robot name (default door)")
    p.add_argument("--id", type=int, default=0, help="robot id to ask for (default: the next free one)")
    p.add_argument("--detect", type=float, default=1.0, help="open when something is this near, m (default 1)")
    p.add_argument("--timeout", type=float, default=3.0, help="close after this long with nothing near, s (default 3)")
    p.add_argument(
        "--policy",
        choices=["proximity", "negotiate"],
        default="proximity",
        help="open when something is detected (default) or for chairs that ask over the radio",
    )
    p.add_argument(
        "--test-door", action="store_true", help="the seed's test door of section 7.4 (1 m leaf along the heading)"
    )
    p.add_argument("--radius", type=float, default=1.6, help="revolving: the drum's inside radius, m (default 1.6)")
    p.add_argument("--wings", type=int, default=3, choices=[3, 4], help="revolving: leaves (default 3)")
    p.add_argument(
        "--leaf",
        type=float,
        default=LEAF_M,
        help="leaf length, m (default 1); a sliding leaf lies along --at's heading and slides that far",
    )


def make(args: argparse.Namespace) -> list[DoorAgent] | list[LeafAgent]:
    """The door the arguments ask for (a revolving door: one agent per leaf)."""
    x, y, d = args.at
    kind = DoorKind(args.kind)
    if kind == DoorKind.REVOLVING:
        return leaves(args.robot_name, Drum(x, y, axis_deg=d, radius_m=args.radius, wings=args.wings), first_id=args.id)
    if args.leaf <= 0.0:
        raise ValueError(f"--leaf is the leaf's length in metres and must be > 0, got {args.leaf:g}")
    spec = door_spec(args.robot_name, kind, x=x, y=y, dir_deg=d, test_door=args.test_door, leaf_m=args.leaf)
    params = DoorParams(kind=kind, detect_m=args.detect, timeout_s=args.timeout, slide_m=args.leaf)
    spec = replace(spec, id=args.id)
    return [DoorAgent(spec, params, negotiate=args.policy == "negotiate")]
