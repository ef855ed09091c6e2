"""Every wire message of iw-zenoh, with the one ``encode`` and the one ``decode``.

UTF-8 JSON on the wire (readable in any MCAP viewer or raw subscriber), one ``msgspec.Struct``
per message; msgspec validates types on decode and writes each message's JSON Schema. Every
message carries ``tick`` and ``sim_time_ns``; robot-scoped ones carry ``robot_id``. Batched
messages (proposed, verdict, state) carry arrays, so a tick costs a handful of messages however
many robots there are. ``revision`` counts changes of the roster and of the obstacles: a node
that sees one it does not know asks ``world/info`` again.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Container, Mapping, Sized
from typing import Annotated, Any, ClassVar, Literal, TypeVar, overload

import msgspec

from iw_zenoh.core.modes import Mode, Profile
from iw_zenoh.errors import DecodeError

__all__ = [
    "COORD_LIMIT",
    "MESSAGE_TYPES",
    "Actions",
    "Control",
    "EVENT_PAYLOADS",
    "AgentLostData",
    "CollisionData",
    "Event",
    "EventData",
    "EventKind",
    "LaggardData",
    "LegacyRefusedData",
    "NoData",
    "ObstacleData",
    "RadioDroppedData",
    "RefusedData",
    "RegisteredData",
    "Heard",
    "Hear",
    "Hit",
    "LabMsg",
    "Message",
    "Obstacle",
    "Outgoing",
    "PoseReport",
    "Proposed",
    "ActionBatch",
    "ChairReading",
    "RadioBatch",
    "RegisterReply",
    "RegisterRequest",
    "RobotSpecMsg",
    "Say",
    "SensorBatch",
    "SensorReading",
    "SerialLinkData",
    "TOPIC_TYPES",
    "Tick",
    "Verdict",
    "WorldInfo",
    "WorldState",
    "decode",
    "encode",
    "event_payload",
    "make_event",
    "encode_sensor_batch",
    "readings_of",
    "json_schema",
    "stamp_of",
]

T = TypeVar("T", bound="Message")

Finite = Annotated[float, msgspec.Meta(description="a finite number")]
INT64_MAX = 2**63 - 1  # every integer on the wire fits 64 bits (numpy arrays, MCAP times)
NonNeg = Annotated[int, msgspec.Meta(ge=0, le=INT64_MAX)]
RobotId = Annotated[int, msgspec.Meta(ge=0, le=INT64_MAX)]
Int64 = Annotated[int, msgspec.Meta(ge=-INT64_MAX - 1, le=INT64_MAX)]
SAY_MAX_BYTES = 100  # Ciber-Rato DCOSS: at most 100 bytes a message
COORD_LIMIT = 1e9  # a pose, power or distance beyond this (m, rad, deg) measures nothing real


# --- consistency checks, run by msgspec on every decode (a ValueError there is a refusal with its
# reason) and on every construction: kept to a few C-speed passes (a 1,000-robot state costs
# 20-30 us more to decode, ~170 us before)


def _lengths(n: int, of: str, arrays: Mapping[str, Sized]) -> None:
    """Refuses arrays that do not hold one value per robot (or per reading)."""
    for name, a in arrays.items():
        if len(a) != n:
            raise ValueError(f"{name} has {len(a)} values for {n} {of}")


def _unique(ids: list[int], name: str = "ids") -> set[int]:
    """Refuses a robot named twice; returns the set of ids."""
    seen = set(ids)
    if len(seen) != len(ids):
        once: set[int] = set()
        twice = next(i for i in ids if i in once or once.add(i))  # type: ignore[func-returns-value]
        raise ValueError(f"{name} name robot {twice} twice")
    return seen


def _magnitudes(arrays: Mapping[str, list[float]], limit: float = COORD_LIMIT) -> None:
    """Refuses an array holding a value beyond ``limit`` either way (its root sum of squares, one
    C pass, bounds every value; JSON carries no NaN, and one built here passes, to be refused
    by its receivers as before)."""
    for name, a in arrays.items():
        if math.hypot(*a) > limit:
            raise ValueError(f"{name} holds a value beyond +-{limit:g}")


def _bounded(values: dict[str, float], limit: float = COORD_LIMIT) -> None:
    """Refuses a number beyond ``limit`` either way."""
    for name, v in values.items():
        if abs(v) > limit:
            raise ValueError(f"{name} must be a finite number within +-{limit:g}, got {v!r}")


class Message(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Base of every wire message."""

    schema: ClassVar[str] = "iw.Message/1"
    tick: NonNeg = 0
    sim_time_ns: NonNeg = 0


Outgoing = tuple[str, Message]  # what logic hands its wiring to publish: a key and a message


# --- registration and world description -----------------------------------------------------


class IrSensorMsg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A proximity sensor (Table 4.4)."""

    id: NonNeg
    x: float = 0.0
    y: float = 0.0
    angle_deg: float = 0.0
    cone_deg: float = 60.0
    range_m: float = 4.0


class NoiseMsg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Gaussian noise on one sensor."""

    mean: float = 0.0
    std: float = 0.0
    enabled: bool = True


class SensorNoiseMsg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Noise of every sensor of a robot; a missing field keeps the default."""

    proximity_m: NoiseMsg | None = None
    proximity_legacy: NoiseMsg | None = None
    compass_deg: NoiseMsg | None = None
    beacon_deg: NoiseMsg | None = None
    gps_m: NoiseMsg | None = None
    gps_heading_deg: NoiseMsg | None = None
    encoder_slip: NoiseMsg | None = None
    motion: NoiseMsg | None = None


class BumperMsg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A contact sensor polygon in the robot frame."""

    id: NonNeg
    corners: list[tuple[float, float]]


class RobotSpecMsg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A robot registration (Tables 4.3-4.5); ranges are checked when it becomes a RobotSpec."""

    name: str
    id: NonNeg = 0
    type: Literal["Simulated", "Real", "Door"] = "Simulated"
    shape: Literal["rect", "circle"] = "rect"
    width: float = 1.0
    height: float = 1.0
    com: float = 0.5
    x: float | None = None
    y: float | None = None
    dir: float | None = None
    max_speed: float = 0.5
    acceleration_curve: float = 0.5
    ir_sensors: list[IrSensorMsg] = []
    bumpers: list[BumperMsg] = []
    ticks_per_m: float = 2000.0
    noise: SensorNoiseMsg | None = None
    legacy: bool = False
    beacon_height: float | None = None  # carries a beacon (Ciber-Rato RobotBeacon)


class RegisterRequest(Message, frozen=True, kw_only=True):
    """Asks the world for a robot (``world/register`` query payload)."""

    schema: ClassVar[str] = "iw.RegisterRequest/1"
    spec: RobotSpecMsg
    agent: str = ""  # the liveliness name of the agent process that drives it
    request_id: str = ""  # the same id asked again gets the same answer (retries are safe)


class RegisterReply(Message, frozen=True, kw_only=True):
    """The world's answer: the accepted spec with id and start pose, or a refusal and why."""

    schema: ClassVar[str] = "iw.RegisterReply/1"
    ok: bool
    robot_id: RobotId = 0
    spec: RobotSpecMsg | None = None
    reason: str = ""


class WallMsg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A wall polygon."""

    corners: list[tuple[float, float]]
    height: float = 4.0

    def __post_init__(self) -> None:
        """Refuses a wall that is no polygon."""
        if len(self.corners) < 3:
            raise ValueError(f"a wall needs at least 3 corners, this one has {len(self.corners)}")


class LabMsg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A lab: size, walls, beacons (x, y, height) and targets (x, y, radius)."""

    name: str
    width: float
    height: float
    walls: list[WallMsg] = []
    beacons: list[tuple[float, float, float]] = []
    targets: list[tuple[float, float, float]] = []


class Obstacle(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A rectangular obstacle added at run time, by name."""

    name: str
    x0: float
    y0: float
    x1: float
    y1: float
    height: float = 1.0


class WorldInfo(Message, frozen=True, kw_only=True):
    """Everything a late joiner needs (the ``world/info`` queryable's answer)."""

    schema: ClassVar[str] = "iw.WorldInfo/1"
    revision: NonNeg
    lab: LabMsg
    grid: list[tuple[float, float, float]] = []
    profile: Profile = Profile.NATIVE
    mode: Mode = Mode.REALTIME
    period_ns: NonNeg
    seed: NonNeg = 0  # seeds numpy's generators, which take no negative seed
    robots: list[RobotSpecMsg] = []
    obstacles: list[Obstacle] = []
    sim: str = "default"

    def __post_init__(self) -> None:
        """Refuses a roster that names a robot twice."""
        if len(self.robots) > 1:
            _unique([r.id for r in self.robots], "robots")


# --- the tick ---------------------------------------------------------------------------------


class Tick(Message, frozen=True, kw_only=True):
    """The clock."""

    schema: ClassVar[str] = "iw.Tick/1"
    period_ns: NonNeg
    mode: Mode = Mode.REALTIME
    running: bool = True
    revision: NonNeg = 0


class Proposed(Message, frozen=True, kw_only=True):
    """Current and proposed poses of every robot for tick n (world to collision)."""

    schema: ClassVar[str] = "iw.Proposed/1"
    revision: NonNeg
    ids: list[RobotId]
    x: list[float]
    y: list[float]
    heading: list[float]
    next_x: list[float]
    next_y: list[float]
    next_heading: list[float]
    linear: list[float]
    active: list[bool]
    # what the state will say if nothing collides (a sensors node computes ahead on it)
    rolled_left: list[float] = []
    rolled_right: list[float] = []
    tick_wall_ns: NonNeg = 0

    def __post_init__(self) -> None:
        """Refuses arrays of different lengths (``rolled_*`` may both be empty: older worlds did
        not send them), a robot named twice, a value beyond any lab."""
        n = len(self.ids)
        poses = {
            "x": self.x,
            "y": self.y,
            "heading": self.heading,
            "next_x": self.next_x,
            "next_y": self.next_y,
            "next_heading": self.next_heading,
            "linear": self.linear,
        }
        rolled = {"rolled_left": self.rolled_left, "rolled_right": self.rolled_right}
        _lengths(n, "robots", {**poses, "active": self.active})
        _lengths(n if self.rolled_left or self.rolled_right else 0, "robots", rolled)
        _unique(self.ids)
        _magnitudes({**poses, **rolled})


class Hit(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One collision: a robot and a wall (index; the lab's wall count is the border) or robot."""

    robot_id: RobotId
    wall: Annotated[int, msgspec.Meta(ge=-1, le=INT64_MAX)] = -1
    other: Annotated[int, msgspec.Meta(ge=-1, le=INT64_MAX)] = -1


class Verdict(Message, frozen=True, kw_only=True):
    """Collision verdict on tick n's proposal (collision to world)."""

    schema: ClassVar[str] = "iw.Verdict/1"
    revision: NonNeg
    ids: list[RobotId]
    collided: list[bool]
    hits: list[Hit] = []

    def __post_init__(self) -> None:
        """Refuses a verdict whose flags are not one per robot, or whose hits name other robots."""
        known = _unique(self.ids)
        _lengths(len(self.ids), "robots", {"collided": self.collided})
        for h in self.hits:
            if h.robot_id not in known or (h.other >= 0 and h.other not in known):
                raise ValueError(f"a hit names robot {h.robot_id} or {h.other}, not in ids")


class WorldState(Message, frozen=True, kw_only=True):
    """Committed state of every robot after tick n."""

    schema: ClassVar[str] = "iw.WorldState/1"
    revision: NonNeg
    ids: list[RobotId]
    x: list[float]
    y: list[float]
    heading: list[float]
    collided: list[bool]
    rolled_left: list[float]
    rolled_right: list[float]
    speed: list[float]
    held: bool = False
    held_reason: str = ""
    tick_wall_ns: NonNeg = 0  # wall clock when the world began this tick (latency diagnostics)

    def __post_init__(self) -> None:
        """Refuses arrays of different lengths, a robot named twice, a value beyond any lab."""
        arrays = {
            "x": self.x,
            "y": self.y,
            "heading": self.heading,
            "rolled_left": self.rolled_left,
            "rolled_right": self.rolled_right,
            "speed": self.speed,
        }
        _lengths(len(self.ids), "robots", {**arrays, "collided": self.collided})
        _unique(self.ids)
        _magnitudes(arrays)


# --- per robot ------------------------------------------------------------------------------


class Actions(Message, frozen=True, kw_only=True):
    """Motor powers (clamped to +-0.15 by the world) and LEDs; ``tick`` is the sensors' tick it answers."""

    schema: ClassVar[str] = "iw.Actions/1"
    robot_id: RobotId
    left: float = 0.0
    right: float = 0.0
    end_led: bool = False
    returning_led: bool = False
    visiting_led: bool = False


class ActionBatch(Message, frozen=True, kw_only=True):
    """Every hosted robot's actions for tick n from one agent process (an agent host with many
    robots sends one message a tick instead of one per robot; the world checks that each robot
    belongs to ``agent``)."""

    schema: ClassVar[str] = "iw.ActionBatch/1"
    agent: str
    actions: list[Actions] = []

    def __post_init__(self) -> None:
        """Refuses a batch that commands a robot twice."""
        if len(self.actions) > 1:
            _unique([a.robot_id for a in self.actions], "actions")


class PoseReport(Message, frozen=True, kw_only=True):
    """A Real robot's own pose from its odometry (augmented reality)."""

    schema: ClassVar[str] = "iw.PoseReport/1"
    robot_id: RobotId
    x: float
    y: float
    dir_deg: float

    def __post_init__(self) -> None:
        """Refuses a pose beyond any lab (the world would move the robot there)."""
        _bounded({"x": self.x, "y": self.y, "dir_deg": self.dir_deg})


class ChairReading(Message, frozen=True, kw_only=True):
    """A real chair's own readings, from its boards over the serial link (``iwz bridge serial``),
    one per board status: what the augmented wheelchair merges with its virtual readings."""

    schema: ClassVar[str] = "iw.ChairReading/1"
    robot_id: RobotId
    link: Literal["up", "down"] = "up"
    pose: tuple[float, float, float]  # odometry: x m, y m, heading deg (drifts, as a real chair's)
    encoders: tuple[Int64, Int64] = (0, 0)
    wheels: tuple[float, float] = (0.0, 0.0)  # the powers the motors run at now
    proximity_ids: list[NonNeg] = []
    proximity_m: list[float | None] = []  # None: nothing in range
    bumpers: list[bool] = []
    battery_v: float = 0.0
    estop: bool = False
    estop_source: Literal["", "computer", "chair"] = ""
    watchdog: bool = False  # the board's own watchdog holds the motors
    fault: NonNeg = 0
    frames: NonNeg = 0  # good frames received so far
    dropped: NonNeg = 0  # corrupt, truncated or out-of-order frames dropped so far
    sent: NonNeg = 0  # frames sent to the chair so far


class SensorReading(Message, frozen=True, kw_only=True):
    """Every reading of tick n for one robot. ``None`` proximity means nothing within range,
    ``None`` beacon means not visible."""

    schema: ClassVar[str] = "iw.SensorReading/1"
    robot_id: RobotId
    proximity_ids: list[Int64]
    proximity_m: list[float | None]
    proximity_legacy: list[float]
    compass_deg: float
    beacons_deg: list[float | None] = []
    gps: tuple[float, float, float]
    ground: Int64 = -1
    collision: bool = False
    encoders: tuple[Int64, Int64] = (0, 0)
    bumpers: list[bool] = []
    tick_wall_ns: NonNeg = 0  # the world's tick start, copied from the state

    def __post_init__(self) -> None:
        """Refuses proximity arrays that are not one value per sensor (one comparison: these
        are built for every robot every tick)."""
        n = len(self.proximity_ids)
        if len(self.proximity_m) != n or len(self.proximity_legacy) != n:
            raise ValueError(
                f"{n} proximity_ids for {len(self.proximity_m)} proximity_m and "
                f"{len(self.proximity_legacy)} proximity_legacy"
            )


class SensorBatch(Message, frozen=True, kw_only=True):
    """Every reading of tick n that one sensors shard computed (for agent hosts and bridges with
    many robots: one message a tick instead of one per robot). The per-robot keys carry the same
    readings."""

    schema: ClassVar[str] = "iw.SensorBatch/1"
    shard: str
    readings: list[SensorReading] = []
    tick_wall_ns: NonNeg = 0
    ids: list[RobotId] = []  # each reading's robot, in order: a reader may decode only its own

    def __post_init__(self) -> None:
        """Refuses a robot read twice, and ``ids`` that do not name each reading's robot."""
        rids = [r.robot_id for r in self.readings]
        _unique(rids, "readings")
        if self.ids and self.ids != rids:
            raise ValueError("ids do not name each reading's robot, in order")


class _SensorBatchOut(msgspec.Struct, frozen=True, kw_only=True):
    """SensorBatch with its readings already encoded (each is also published on its own key)."""

    tick: int
    sim_time_ns: int
    shard: str
    readings: list[msgspec.Raw]
    tick_wall_ns: int
    ids: list[int]


class _SensorBatchIn(Message, frozen=True, kw_only=True):
    """SensorBatch with its readings left encoded, to decode only some."""

    schema: ClassVar[str] = "iw.SensorBatch/1"
    shard: str
    readings: list[msgspec.Raw] = []
    tick_wall_ns: NonNeg = 0
    ids: list[RobotId] = []

    def __post_init__(self) -> None:
        """Refuses ids that are not one per reading (or none), or that name a robot twice."""
        if self.ids:
            if len(self.ids) != len(self.readings):
                raise ValueError(f"{len(self.ids)} ids for {len(self.readings)} readings")
            _unique(self.ids)


class Say(Message, frozen=True, kw_only=True):
    """A radio message to send (at most 100 bytes of UTF-8; longer ones are dropped and counted)."""

    schema: ClassVar[str] = "iw.Say/1"
    robot_id: RobotId
    text: str


class Heard(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One message heard: who said it, from how far, and what."""

    sender: RobotId
    distance_m: float
    text: str


class Hear(Message, frozen=True, kw_only=True):
    """Messages one robot heard in tick n, in sender order."""

    schema: ClassVar[str] = "iw.Hear/1"
    robot_id: RobotId
    messages: list[Heard] = []


class RadioBatch(Message, frozen=True, kw_only=True):
    """Everything the radio delivered in tick n (for agent hosts: one message, then no race)."""

    schema: ClassVar[str] = "iw.RadioBatch/1"
    hear: list[Hear] = []

    def __post_init__(self) -> None:
        """Refuses a batch that names a robot twice."""
        if len(self.hear) > 1:
            _unique([h.robot_id for h in self.hear], "hear")


# --- control and events -----------------------------------------------------------------------


class Control(Message, frozen=True, kw_only=True):
    """A command to the world."""

    schema: ClassVar[str] = "iw.Control/1"
    command: Literal[
        "start",
        "pause",
        "step",
        "stop",
        "remove",
        "add_obstacle",
        "move_obstacle",
        "remove_obstacle",
        "seek",
        "estop",
        "clear",
    ]
    robot_id: RobotId = 0
    obstacle: Obstacle | None = None
    steps: Annotated[int, msgspec.Meta(ge=1, le=INT64_MAX)] = 1
    at_ns: NonNeg = 0  # seek: the simulation time to go to (replays)


class EventKind(enum.StrEnum):
    """What an :class:`Event` says happened (also the last chunk of its key, ``events/{kind}``)."""

    COLLISION = "collision"  # a robot touched a wall or another robot (world)
    WATCHDOG = "watchdog"  # a robot sent no actions for too long: motors zeroed (world)
    WATCHDOG_CLEARED = "watchdog-cleared"  # ... and is commanded again (world)
    REGISTERED = "registered"  # a robot joined (world)
    REFUSED = "refused"  # a registration was refused, with its reason (world)
    REMOVED = "removed"  # a robot left: asked, or its agent gone past the grace period (world)
    AGENT_LOST = "agent-lost"  # an agent process is gone: its robots stopped (world)
    SENSORS_LOST = "sensors-lost"  # no sensors process is alive: lock-step waits (world)
    HOLDING = "holding"  # every robot held still: no collision verdict (world)
    RESUMED = "resumed"  # collision verdicts are back (world)
    STARTED = "started"  # a start control ran the simulation (world)
    PAUSED = "paused"  # a pause control stopped the ticks (world)
    STOPPED = "stopped"  # a stop control, or the duration reached (world)
    OBSTACLE = "obstacle"  # an obstacle was added, moved or removed (world)
    BAD_CONTROL = "bad-control"  # a control the world cannot do (world)
    BAD_MESSAGE = "bad-message"  # a malformed or misaddressed message, dropped (any node)
    LAGGARD = "laggard"  # lock-step: robots whose actions did not come in time (world)
    RADIO_DROPPED = "radio-dropped"  # radio messages dropped this tick, counted (radio)
    LEGACY_REFUSED = "legacy-refused"  # a legacy client's datagram refused (legacy bridge)
    LEGACY_FINISHED = "legacy-finished"  # the legacy simulation reached SimTime (legacy bridge)
    SERIAL_LINK = "serial-link"  # a real chair is heard on its serial line (serial bridge)
    SERIAL_LINK_LOST = "serial-link-lost"  # ... and no longer: the robot is held (serial bridge)
    SERIAL_ESTOP = "serial-estop"  # an operator's e-stop reached the chair's bridge: latched (serial bridge)
    SERIAL_CLEAR = "serial-clear"  # an operator cleared the chair's e-stop (serial bridge)


class Event(Message, frozen=True, kw_only=True):
    """Something happened: a collision, a registration or refusal, a timeout, a lost process...

    ``data`` is the kind's payload (:data:`EVENT_PAYLOADS`) as a JSON object: build an event with
    :func:`make_event` and read its payload back with :func:`event_payload`.
    """

    schema: ClassVar[str] = "iw.Event/1"
    kind: EventKind
    reason: str = ""
    robot_id: Annotated[int, msgspec.Meta(ge=-1, le=INT64_MAX)] = -1
    key: str = ""
    source: str = ""
    data: dict[str, Any] = {}


# --- event payloads: what each kind of event carries in its ``data`` ---------------------------


class EventData(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Base of every event payload (written in full unless a payload says otherwise)."""


class NoData(EventData, frozen=True, kw_only=True):
    """The payload of a kind whose reason says it all (``data`` is ``{}``)."""


class CollisionData(EventData, frozen=True, kw_only=True):
    """Where a robot hit, and what: wall indices (the lab's wall count is the border) and robots."""

    x: float
    y: float
    walls: list[Int64] = []
    robots: list[RobotId] = []


class RegisteredData(EventData, frozen=True, kw_only=True):
    """The agent process that drives the new robot (empty: none named)."""

    agent: str = ""


class RefusedData(EventData, frozen=True, kw_only=True):
    """The refused robot's name and agent (both empty when the request did not even decode)."""

    name: str = ""
    agent: str = ""


class AgentLostData(EventData, frozen=True, kw_only=True):
    """The agent process that is gone."""

    agent: str


class ObstacleData(EventData, frozen=True, kw_only=True):
    """The obstacle added, moved or removed."""

    name: str


class LaggardData(EventData, frozen=True, kw_only=True):
    """The robots whose actions did not come in time."""

    robots: list[RobotId]


class RadioDroppedData(EventData, frozen=True, kw_only=True, omit_defaults=True):
    """Radio messages dropped, by cause; a cause with no drop is left out."""

    too_long: NonNeg = 0  # over the bytes a message may have
    unknown_sender: NonNeg = 0  # said by a robot the state does not list
    over_budget: NonNeg = 0  # past what a robot may hear a tick


class LegacyRefusedData(EventData, frozen=True, kw_only=True):
    """The legacy client refused, as ``host:port`` (the port of a sample when its address had
    several refused since the last event), with how many of its datagrams were refused since the
    last event (``count``) and how many of those were over the flood limit, dropped unread."""

    peer: str
    count: int = 1
    dropped: int = 0


class SerialLinkData(EventData, frozen=True, kw_only=True):
    """The chair's serial device or pyserial URL."""

    port: str


EVENT_PAYLOADS: dict[EventKind, type[EventData]] = {
    EventKind.COLLISION: CollisionData,
    EventKind.WATCHDOG: NoData,
    EventKind.WATCHDOG_CLEARED: NoData,
    EventKind.REGISTERED: RegisteredData,
    EventKind.REFUSED: RefusedData,
    EventKind.REMOVED: NoData,
    EventKind.AGENT_LOST: AgentLostData,
    EventKind.SENSORS_LOST: NoData,
    EventKind.HOLDING: NoData,
    EventKind.RESUMED: NoData,
    EventKind.STARTED: NoData,
    EventKind.PAUSED: NoData,
    EventKind.STOPPED: NoData,
    EventKind.OBSTACLE: ObstacleData,
    EventKind.BAD_CONTROL: NoData,
    EventKind.BAD_MESSAGE: NoData,
    EventKind.LAGGARD: LaggardData,
    EventKind.RADIO_DROPPED: RadioDroppedData,
    EventKind.LEGACY_REFUSED: LegacyRefusedData,
    EventKind.LEGACY_FINISHED: NoData,
    EventKind.SERIAL_LINK: SerialLinkData,
    EventKind.SERIAL_LINK_LOST: SerialLinkData,
    EventKind.SERIAL_ESTOP: NoData,
    EventKind.SERIAL_CLEAR: NoData,
}  # the payload type of each kind of event

P = TypeVar("P", bound=EventData)


def make_event(
    kind: EventKind,
    payload: EventData | None = None,
    *,
    reason: str = "",
    tick: int = 0,
    sim_time_ns: int = 0,
    robot_id: int = -1,
    key: str = "",
    source: str = "",
) -> Event:
    """An event of ``kind`` carrying ``payload`` in its ``data``.

    Args:
        kind: What happened.
        payload: Its payload, of the kind's type in :data:`EVENT_PAYLOADS` (``None``: :class:`NoData`).
        reason: What happened, for people.
        tick: The tick it happened in.
        sim_time_ns: The simulation time it happened at (ns).
        robot_id: The robot concerned (-1: none).
        key: The key concerned (a bad message's, a bad control's).
        source: Who says so (``world``, ``role/name``).

    Returns:
        The event.

    Raises:
        TypeError: When the payload is not the kind's.
    """
    data = NoData() if payload is None else payload
    expected = EVENT_PAYLOADS[kind]
    if type(data) is not expected:
        raise TypeError(f"a {kind} event carries {expected.__name__}, not {type(data).__name__}")
    return Event(
        tick=tick,
        sim_time_ns=sim_time_ns,
        kind=kind,
        reason=reason,
        robot_id=robot_id,
        key=key,
        source=source,
        data=msgspec.to_builtins(data),
    )


@overload
def event_payload(ev: Event) -> EventData: ...
@overload
def event_payload(ev: Event, expected: type[P]) -> P: ...
def event_payload(ev: Event, expected: type[EventData] | None = None) -> EventData:
    """The payload of an event, as its kind's struct.

    Args:
        ev: The event (decoded, or made here).
        expected: The payload type the caller reads (a check: it must be the kind's).

    Returns:
        The payload.

    Raises:
        DecodeError: When the kind is unknown or ``data`` is not that kind's payload (naming the field).
        TypeError: When ``expected`` is not the kind's payload type.
    """
    try:
        kind = EventKind(ev.kind)
    except ValueError:
        raise DecodeError(f"{Event.schema}: no event kind {ev.kind!r}") from None
    cls = EVENT_PAYLOADS[kind]
    if expected is not None and expected is not cls:
        raise TypeError(f"a {kind} event carries {cls.__name__}, not {expected.__name__}")
    try:
        return msgspec.convert(ev.data, cls)
    except msgspec.ValidationError as e:
        raise DecodeError(f"{Event.schema} {kind} data: {e}") from None


MESSAGE_TYPES: tuple[type[Message], ...] = (
    RegisterRequest,
    RegisterReply,
    WorldInfo,
    Tick,
    Proposed,
    Verdict,
    WorldState,
    Actions,
    ActionBatch,
    PoseReport,
    ChairReading,
    SensorReading,
    SensorBatch,
    Say,
    Hear,
    RadioBatch,
    Control,
    Event,
)

TOPIC_TYPES: dict[str, type[Message]] = {
    "info": WorldInfo,
    "tick": Tick,
    "proposed": Proposed,
    "verdict": Verdict,
    "state": WorldState,
    "control": Control,
    "radio": RadioBatch,
    "sensor_batch": SensorBatch,
    "action_batch": ActionBatch,
    "event": Event,
    "spec": RegisterReply,
    "actions": Actions,
    "pose_report": PoseReport,
    "chair": ChairReading,
    "sensors": SensorReading,
    "say": Say,
    "hear": Hear,
}  # the message type of each kind of key (see keys.topic_kind)


class _Stamp(msgspec.Struct):
    sim_time_ns: int = 0
    tick: int = 0


_STAMP = msgspec.json.Decoder(_Stamp)


def stamp_of(data: bytes) -> tuple[int, int]:
    """``(tick, sim_time_ns)`` of any message, cheaply, each within 0..2**63-1; ``(0, 0)`` when
    it does not say."""
    try:
        s = _STAMP.decode(data)
    except (msgspec.DecodeError, msgspec.ValidationError):
        return 0, 0
    return min(max(0, s.tick), INT64_MAX), min(max(0, s.sim_time_ns), INT64_MAX)


_ENCODER = msgspec.json.Encoder()
_DECODERS: dict[type[Any], msgspec.json.Decoder[Any]] = {}


def encode(msg: msgspec.Struct) -> bytes:
    """Encodes any message (or derived channel, such as the Foxglove scene) as UTF-8 JSON.

    JSON has no NaN or infinity: msgspec writes them as ``null``, which a receiver refuses for a
    plain float field (fields that may be unknown are ``float | None``).
    """
    return _ENCODER.encode(msg)


def encode_sensor_batch(
    tick: int, sim_time_ns: int, shard: str, readings: list[bytes], tick_wall_ns: int, ids: list[int]
) -> bytes:
    """A :class:`SensorBatch` from readings encoded once already (no second encoding); ``ids``
    names each reading's robot."""
    return _ENCODER.encode(
        _SensorBatchOut(
            tick=tick,
            sim_time_ns=sim_time_ns,
            shard=shard,
            readings=[msgspec.Raw(r) for r in readings],
            tick_wall_ns=tick_wall_ns,
            ids=ids,
        )
    )


def readings_of(data: bytes, wanted: Container[int]) -> list[SensorReading]:
    """The readings of the robots in ``wanted`` from an encoded :class:`SensorBatch`, decoding
    only those (a host of 250 robots in a batch of 1,000 decodes a quarter of it).

    Raises:
        DecodeError: When the batch, or one of the wanted readings, is malformed, or a reading
            is not the robot its ``ids`` entry names.
    """
    b = decode(data, _SensorBatchIn)
    if not b.ids and b.readings:  # a sender that does not name them: decode every reading
        return [r for r in decode(data, SensorBatch).readings if r.robot_id in wanted]
    out: list[SensorReading] = []  # ids are one per reading (checked on decode)
    for rid, raw in zip(b.ids, b.readings, strict=True):
        if rid in wanted:
            r = decode(raw, SensorReading)
            if r.robot_id != rid:
                raise DecodeError(f"iw.SensorBatch/1: the reading listed for robot {rid} is robot {r.robot_id}'s")
            out.append(r)
    return out


def decode(data: bytes, kind: type[T]) -> T:
    """Decodes and validates a message of a known type.

    Args:
        data: The payload.
        kind: The message class expected on this key.

    Returns:
        The message.

    Raises:
        DecodeError: Naming the field and the reason; never a half-filled object.
    """
    dec = _DECODERS.get(kind)
    if dec is None:
        dec = _DECODERS[kind] = msgspec.json.Decoder(kind)
    try:
        msg: T = dec.decode(data)
    except msgspec.ValidationError as e:
        raise DecodeError(f"{kind.schema}: {e}") from None
    except msgspec.DecodeError as e:
        raise DecodeError(f"{kind.schema}: not JSON: {e}") from None
    return msg


def json_schema(kind: type[msgspec.Struct]) -> dict[str, Any]:
    """The JSON Schema of a message class (what the recorder writes per channel)."""
    schema: dict[str, Any] = msgspec.json.schema(kind)
    return schema
