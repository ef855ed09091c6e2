"""Messages of one robot: its actions, pose reports, readings (and their batches) and radio."""

from __future__ import annotations

import math
from collections.abc import Container
from typing import ClassVar, Literal, NamedTuple

import msgspec

from iw_zenoh.errors import DecodeError
from iw_zenoh.messages.wire import _ENCODER, Int64, Message, NonNeg, RobotId, _bounded, _unique, decode

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


class LaserScan(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One laser scanner's sweep: a range per beam, first beam first (``None``: nothing within
    range); the beams' directions are the scanner's spec (``LaserSpec``)."""

    id: NonNeg
    ranges: list[float | None]


class Pose(NamedTuple):
    """A pose in the lab's frame, in the core's units (what :attr:`SensorReading.pose` gives).

    Attributes:
        x_m: x, metres.
        y_m: y, metres.
        heading_rad: Heading, radians counter-clockwise from the x axis, in [-pi, pi].
    """

    x_m: float
    y_m: float
    heading_rad: float


class SensorReading(Message, frozen=True, kw_only=True):
    """Every reading of tick n for one robot. ``None`` proximity means nothing within range,
    ``None`` beacon means not visible.

    On the wire ``gps`` is ``(x m, y m, heading deg)`` and ``compass_deg`` degrees; an agent reads
    them in the core's units as :attr:`pose` (``Pose(x_m, y_m, heading_rad)``) and :attr:`compass_rad`.
    """

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
    # added after /1 shipped: left out of the JSON when unset (no scanner), so it reads as before
    lasers: list[LaserScan] | msgspec.UnsetType = msgspec.UNSET

    def __post_init__(self) -> None:
        """Refuses proximity arrays that are not one value per sensor (one comparison: these
        are built for every robot every tick)."""
        n = len(self.proximity_ids)
        if len(self.proximity_m) != n or len(self.proximity_legacy) != n:
            raise ValueError(
                f"{n} proximity_ids for {len(self.proximity_m)} proximity_m and "
                f"{len(self.proximity_legacy)} proximity_legacy"
            )

    @property
    def pose(self) -> Pose:
        """The GPS pose, ``Pose(x_m, y_m, heading_rad)`` (noisy unless the spec's GPS noise is off)."""
        x, y, d = self.gps
        return Pose(x, y, math.radians(d))

    @property
    def compass_rad(self) -> float:
        """The compass heading, radians counter-clockwise from the x axis."""
        return math.radians(self.compass_deg)


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
