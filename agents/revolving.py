"""A revolving door's leaves and a chair's passage through it, pure: readings and the radio in,
motor powers and radio texts out (the geometry and motions: ``iw_zenoh/core/revolving.py``; the
messages: ``agents/passage.py``).

The door (:class:`RevolvingDoor`, one per door, shared by its leaves, each a :class:`LeafAgent`
robot) queues the chairs that ask, in order of arrival, and serves one at a time: it turns half
a sector when the next chair's side faces a leaf, so that a sector faces it; grants it the
doorway; waits for it to say IN; turns half a circle along a smooth profile, saying TURN each
tick; and, once the chair says PASSED, serves the next. A leaf that touches anything holds the
whole door still until it is clear.

The chair (:class:`RevolvingPilot`, driving for the chair's own agent near the door) waits and
asks a metre outside the drum, beside the axis (a chair coming out drives along it); granted, it
lines up on the axis and drives in to the ring, turns on the spot
to face the way the door turns, says IN, rides the ring beside the door (following the door's
TURN messages), turns back to the axis and drives out, then says PASSED.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, replace

from iw_zenoh.agent import Command
from iw_zenoh.core.revolving import Drum, profile, ride_pose, to_powers, track, travel_deg, turn_rate
from iw_zenoh.core.spec import IrSensorSpec, NoiseSpec, RobotSpec, RobotType, SensorNoise
from iw_zenoh.messages import Heard, SensorReading

from .passage import Arbiter, Client, In, Message, Turn, join, parse_all

__all__ = ["MID_WHEEL_SENSORS", "LeafAgent", "Phase", "RevolvingDoor", "RevolvingPilot", "leaves"]

EXACT = SensorNoise(*(NoiseSpec(0.0, 0.0, enabled=False),) * 8)
LEAF_THICK_M = 0.1
LEAF_COM = (
    0.98  # the leaf reaches this share of its length ahead of its centre of movement: the hub is at its inner end
)
LEAF_GAIN = 2.0  # leaf heading error to turn rate, 1/s
CARRY_S = 24.0  # a half turn with a chair: 7.5 deg/s at its fastest (0.12 m/s on a 0.9 m ring)
ALIGN_S = 6.0  # half a sector, empty
HOLD_S = 180.0  # the longest a chair may hold the door (from its grant, while it still comes, to PASSED)
WAIT_GAP_M = 1.0  # a chair lines up this far outside the drum, on the axis ...
WAIT_ASIDE_M = 1.1  # ... from where it waits, this far to the right, out of a leaving chair's way
LEAVE_GAP_M = 2.5  # a chair is through this far outside the drum on the other side: past the waiting place
ENGAGE_M = 5.0  # the pilot drives from this near the hub
CRAWL_MPS = 0.15  # the pilot's speed in and out of the drum
SETTLE_DEG = 1.5  # a turn on the spot is done this near its heading
NEAR_M = 0.1  # a place is reached this near (driving in along the axis straightens what is left)
MID_WHEEL_SENSORS = tuple(
    IrSensorSpec(i, x, y, a, 60.0, 3.0)
    for i, (x, y, a) in enumerate(
        ((0.48, 0.24, 0.0), (0.48, -0.24, 0.0), (0.3, 0.28, 90.0), (0.3, -0.28, -90.0))
        + ((-0.2, 0.28, 90.0), (-0.2, -0.28, -90.0), (-0.48, 0.24, 180.0), (-0.48, -0.24, 180.0))
    )
)  # the prototype's eight sonars, moved onto a 1.0 x 0.6 mid-wheel-drive body


class Phase(enum.StrEnum):
    """Where the door is in serving a chair."""

    IDLE = "idle"
    WAIT_IN = "wait-in"
    CARRY = "carry"
    DELIVERED = "delivered"


class RevolvingDoor:
    """The door's controller, shared by its leaves.

    Args:
        drum: The door's geometry.
        dt_s: Tick length, s.
    """

    def __init__(self, drum: Drum, dt_s: float = 0.1) -> None:
        self.drum = drum
        self.dt_s = dt_s
        self.arbiter: Arbiter | None = None
        self.rest_deg = 0.0  # the turn it stands at, or started its current motion from
        self.span_deg = 0.0  # the current motion's turn (0: at rest)
        self.span_s = 1.0
        self.elapsed_s = 0.0
        self.phase = Phase.IDLE
        self.tick = -1
        self.blocked_tick = -10
        self._outbox: list[str] = []

    def turn(self, ahead_s: float = 0.0) -> tuple[float, float]:
        """The door's planned turn ``ahead_s`` from now: (deg from its start, deg/s)."""
        if self.span_deg == 0.0:
            return self.rest_deg, 0.0
        done, rate = profile(self.elapsed_s + ahead_s, self.span_deg, self.span_s)
        return self.rest_deg + done, rate

    def advance(self, tick: int, *, collided: bool) -> None:
        """Moves the plan on once a tick (whichever leaf comes first); a leaf in contact holds it."""
        if collided:
            self.blocked_tick = tick
        if tick <= self.tick:
            return
        self.tick = tick
        if self.span_deg == 0.0 or self.blocked_tick >= tick - 1:
            return
        self.elapsed_s += self.dt_s
        if self.elapsed_s >= self.span_s:
            self.rest_deg += self.span_deg
            self.span_deg, self.elapsed_s = 0.0, 0.0
            if self.phase == Phase.CARRY:
                self.phase = Phase.DELIVERED

    def _move(self, span_deg: float, span_s: float) -> None:
        self.span_deg, self.span_s, self.elapsed_s = span_deg, span_s, 0.0

    def talk(self, now_s: float, heard: list[Message]) -> str | None:
        """Leaf 0's part each tick: serves the queue; returns what to say."""
        arb = self.arbiter
        if arb is None:
            return None
        head = arb.queue[0] if arb.queue else None
        at_rest = self.span_deg == 0.0
        ready = at_rest and self.phase == Phase.IDLE and head is not None
        door_open = ready and head is not None and self.drum.faces(self.rest_deg, head.side or 1)
        texts = [a.text() for a in arb.step(heard, now_s, door_open)]
        holder = arb.holder
        if holder is None and self.phase != Phase.CARRY:
            self.phase = Phase.IDLE
        elif self.phase == Phase.IDLE and holder is not None:
            self.phase = Phase.WAIT_IN
        if self.phase == Phase.WAIT_IN and any(
            isinstance(m, In) and (m.door, m.chair) == (arb.door, holder) for m in heard
        ):
            self.phase = Phase.CARRY
            self._move(180.0, CARRY_S)
        if self.phase == Phase.IDLE and at_rest and holder is None and arb.queue:
            side = arb.queue[0].side or 1
            if not self.drum.faces(self.rest_deg, side):
                self._move(0.5 * self.drum.sector_deg, ALIGN_S)
        if holder is not None and self.phase in (Phase.CARRY, Phase.DELIVERED):
            turned, rate = self.turn()
            start = self.rest_deg if self.phase == Phase.CARRY else self.rest_deg - 180.0
            texts.append(Turn(arb.door, holder, turned - start, rate, now_s).text())
        say, self._outbox = join(self._outbox + texts)
        return say

    def leaf_command(self, k: int, heading_deg: float, spec: RobotSpec) -> tuple[float, float]:
        """Leaf ``k``'s motor powers: turn on the spot after the plan (as it will be next tick)."""
        turned, rate = self.turn(self.dt_s)
        err = math.remainder(self.drum.leaf_heading_deg(k, turned) - heading_deg, 360.0)
        w = math.radians(rate) + LEAF_GAIN * math.radians(err)
        return to_powers(0.0, w, wheel_base_m=spec.height_m, max_speed_mps=spec.max_speed_mps)


class LeafAgent:
    """One leaf of a revolving door, a Door robot; leaf 0 also speaks for the door.

    Args:
        door: The door's shared controller.
        k: Which leaf.
        spec: The leaf's body.
    """

    def __init__(self, door: RevolvingDoor, k: int, spec: RobotSpec) -> None:
        self.door = door
        self.k = k
        self._spec = spec

    def spec(self) -> RobotSpec:
        """The leaf to register."""
        return self._spec

    def on_registered(self, robot_id: int, spec: RobotSpec) -> None:
        """Leaf 0's id is the door's id in the protocol."""
        if self.k == 0:
            self.door.arbiter = Arbiter(robot_id, hold_s=HOLD_S)

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """One tick: the plan moves on, leaf 0 serves the queue, the leaf follows the plan."""
        self.door.advance(reading.tick, collided=reading.collision)
        say = None
        if self.k == 0:
            say = self.door.talk(reading.sim_time_ns / 1e9, [m for h in heard for m in parse_all(h.text)])
        left, right = self.door.leaf_command(self.k, reading.gps[2], self._spec)
        return Command(left, right, say=say)


def leaves(name: str, drum: Drum, *, first_id: int = 0, dt_s: float = 0.1) -> list[LeafAgent]:
    """A revolving door's leaves, sharing one controller; ids ``first_id``, ``first_id + 1``...
    (0: the next free ones)."""
    door = RevolvingDoor(drum, dt_s)
    out = []
    for k in range(drum.wings):
        spec = RobotSpec(
            f"{name[:17]}-{k}",
            id=first_id + k if first_id else 0,
            type=RobotType.DOOR,
            width_m=drum.leaf_m / LEAF_COM,
            height_m=LEAF_THICK_M,
            com=LEAF_COM,
            x_m=drum.hub_x,
            y_m=drum.hub_y,
            dir_deg=math.remainder(drum.leaf_heading_deg(k, 0.0), 360.0),
            ir_sensors=(IrSensorSpec(0, 0.0, 0.0, 0.0, 10.0, 0.1),),  # it steers by its plan, not by what it sees
            noise=EXACT,
            max_speed_mps=0.5,
            acceleration_curve=0.1,
        )
        out.append(LeafAgent(door, k, spec))
    return out


@dataclass
class RevolvingPilot:
    """Drives a chair through a revolving door, for the chair's own agent.

    Args:
        drum: The door's geometry.
        door: The door's id (its leaf 0).
        spec: The chair (a turn on the spot must fit a sector: see ``core/revolving.py``).
    """

    drum: Drum
    door: int
    spec: RobotSpec
    stage: str = "away"
    side: int = 1
    client: Client | None = None
    last_turn: Turn | None = None
    settled: int = 0

    def on_registered(self, robot_id: int) -> None:
        """Learns the chair's id (the protocol names chairs by robot id)."""
        self.client = Client(self.door, robot_id)

    def engaged(self, x: float, y: float) -> bool:
        """Whether the pilot drives now (near the door and not through it)."""
        if self.stage == "away" and math.hypot(x - self.drum.hub_x, y - self.drum.hub_y) < ENGAGE_M:
            self.side = self.drum.side_of(x, y)
            self.stage = "approach"
            if self.client is not None:
                self.client.side = self.side
        return self.stage not in ("away", "done")

    def step(self, now_s: float, pose: tuple[float, float, float], heard: list[Message]) -> Command:
        """One tick near the door: the motors and what to say."""
        assert self.client is not None, "on_registered first"
        self.client.hear(heard, now_s)
        for m in heard:
            if isinstance(m, Turn) and (m.door, m.chair) == (self.door, self.client.chair):
                self.last_turn = m
        v, w = self._drive(now_s, pose)
        texts = []
        said = self.client.say(now_s, wants=True, eta_s=0.0, through=False)
        if said:
            texts.append(said)
        if self.stage == "ready":
            texts.append(In(self.door, self.client.chair).text())
        left, right = to_powers(v, w, wheel_base_m=self.spec.height_m, max_speed_mps=self.spec.max_speed_mps)
        return Command(left, right, say=join(texts)[0])

    def farewell(self, now_s: float) -> str | None:
        """Once through, what the chair still says while its own agent drives: PASSED, three times."""
        if self.stage != "done" or self.client is None:
            return None
        return self.client.say(now_s, wants=False, eta_s=0.0, through=True)

    def _drive(self, now_s: float, pose: tuple[float, float, float]) -> tuple[float, float]:
        d, s = self.drum, self.side
        heading = travel_deg(d, s)
        if self.stage == "approach":
            return self._go(pose, self._waiting_place(), heading, then="wait")
        if self.stage == "wait":
            if self.client is not None and self.client.granted(now_s):
                self.stage = "line-up"
            return 0.0, 0.0
        if self.stage == "line-up":
            return self._go(pose, d.point(-(d.radius_m + WAIT_GAP_M), s), heading, then="enter")
        if self.stage == "enter":
            return self._go(pose, d.point(-d.ring_m, s), heading, then="turn-in", line=True)
        if self.stage == "turn-in":
            return self._turn(pose, heading - 90.0, then="ready")
        if self.stage == "ready":
            if self.last_turn is not None:
                self.stage = "ride"
            return 0.0, 0.0
        if self.stage == "ride":
            return self._ride(now_s, pose)
        if self.stage == "turn-out":
            return self._turn(pose, heading, then="leave")
        if self.stage == "leave":
            return self._go(pose, d.point(d.radius_m + LEAVE_GAP_M, s), heading, then="done", line=True)
        return 0.0, 0.0

    def _waiting_place(self) -> tuple[float, float]:
        """Where the chair waits its turn: a metre outside the drum, WAIT_ASIDE_M to the right of
        the axis, out of the way of a chair coming out."""
        x, y = self.drum.point(-(self.drum.radius_m + WAIT_GAP_M), self.side)
        right = math.radians(travel_deg(self.drum, self.side) - 90.0)
        return x + WAIT_ASIDE_M * math.cos(right), y + WAIT_ASIDE_M * math.sin(right)

    def _go(
        self,
        pose: tuple[float, float, float],
        to: tuple[float, float],
        heading: float,
        *,
        then: str,
        line: bool = False,
    ) -> tuple[float, float]:
        """Drives to ``to`` (along the axis when ``line``: no turning away from it), then faces
        ``heading`` and moves on to stage ``then``."""
        dist = math.hypot(to[0] - pose[0], to[1] - pose[1])
        ahead = math.degrees(math.atan2(to[1] - pose[1], to[0] - pose[0]))
        if line:
            h = math.radians(heading)
            along = (to[0] - pose[0]) * math.cos(h) + (to[1] - pose[1]) * math.sin(h)
            if along <= 0.01:
                self.stage = then
                return 0.0, 0.0
            v, w = track(pose, (to[0], to[1], heading), 0.0, 0.0)
            return min(CRAWL_MPS, max(0.0, v)), w
        if dist > NEAR_M:
            if abs(math.remainder(ahead - pose[2], 360.0)) > 20.0:
                return 0.0, turn_rate(pose[2], ahead)
            return min(2 * CRAWL_MPS, 0.8 * dist), turn_rate(pose[2], ahead, gain=2.0)
        return self._turn(pose, heading, then=then)

    def _turn(self, pose: tuple[float, float, float], heading: float, *, then: str) -> tuple[float, float]:
        """Turns on the spot to ``heading``; a few ticks within SETTLE_DEG move on to ``then``."""
        if abs(math.remainder(heading - pose[2], 360.0)) < SETTLE_DEG:
            self.settled += 1
            if self.settled >= 3:
                self.settled, self.stage = 0, then
            return 0.0, 0.0
        self.settled = 0
        return 0.0, turn_rate(pose[2], heading)

    def _ride(self, now_s: float, pose: tuple[float, float, float]) -> tuple[float, float]:
        """Rides the ring beside the door, where its last TURN says it is by the next tick."""
        t = self.last_turn
        assert t is not None
        done = min(180.0, t.done_deg + t.rate_dps * max(0.0, now_s + 0.1 - t.t_s))
        target = ride_pose(self.drum, self.side, done)
        w_ref = math.radians(t.rate_dps)
        if t.done_deg >= 180.0 - 1e-6 and t.rate_dps == 0.0:
            x, y, _ = target
            if math.hypot(x - pose[0], y - pose[1]) < 0.05:
                self.stage = "turn-out"
                return 0.0, 0.0
        return track(pose, target, self.drum.ring_m * w_ref, w_ref)


def mid_wheel_chair(spec: RobotSpec) -> RobotSpec:
    """``spec`` as a mid-wheel-drive chair (1.0 x 0.6, centre of movement in the middle)."""
    return replace(spec, width_m=1.0, height_m=0.6, com=0.5, ir_sensors=MID_WHEEL_SENSORS)
