"""Messages of the world as a whole: registration, its description, and the tick's batches
(proposal, verdict, committed state)."""

from __future__ import annotations

from typing import Annotated, Any, ClassVar, Literal

import msgspec

from iw_zenoh.core.modes import Mode, Profile
from iw_zenoh.messages.wire import INT64_MAX, Message, NonNeg, RobotId, _lengths, _magnitudes, _unique

# --- registration and world description -----------------------------------------------------


class IrSensorMsg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A proximity sensor (Table 4.4)."""

    id: NonNeg
    x_m: float = 0.0
    y_m: float = 0.0
    angle_deg: float = 0.0
    cone_deg: float = 60.0
    range_m: float = 4.0


class LaserMsg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A 2D laser range finder: ``beams`` rays over ``fov_deg`` centred on ``angle_deg``."""

    id: NonNeg
    x_m: float = 0.0
    y_m: float = 0.0
    angle_deg: float = 0.0
    fov_deg: float = 270.0
    beams: Annotated[int, msgspec.Meta(ge=1, le=INT64_MAX)] = 64
    range_m: float = 10.0


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
    # added after /1 shipped: left out of the JSON when unset, so a spec without it reads as before
    laser_m: NoiseMsg | msgspec.UnsetType = msgspec.UNSET


class BumperMsg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A contact sensor polygon in the robot frame."""

    id: NonNeg
    corners: list[tuple[float, float]]


class RobotSpecMsg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A robot registration (Tables 4.3-4.5); ranges are checked when it becomes a RobotSpec.

    Its fields are named as :class:`~iw_zenoh.core.spec.RobotSpec`'s, units and all (``width_m``,
    ``max_speed_mps``, ``dir_deg``), in Python, spec files, scenarios and on the wire alike; the
    names they had before (``width``, ``max_speed``, ``dir``...) are :data:`RENAMED_SPEC_FIELDS`, still
    read from recordings written before (:func:`upgrade_spec_names`); the schemas keep their /1, as
    every old message still decodes.
    """

    name: str
    id: NonNeg = 0
    type: Literal["Simulated", "Real", "Door"] = "Simulated"
    shape: Literal["rect", "circle"] = "rect"
    width_m: float = 1.0
    height_m: float = 1.0
    com: float = 0.5
    x_m: float | None = None
    y_m: float | None = None
    dir_deg: float | None = None
    max_speed_mps: float = 0.5
    acceleration_curve: float = 0.5
    ir_sensors: list[IrSensorMsg] = []
    bumpers: list[BumperMsg] = []
    ticks_per_m: float = 2000.0
    noise: SensorNoiseMsg | None = None
    legacy: bool = False
    beacon_height_m: float | None = None  # carries a beacon (Ciber-Rato RobotBeacon)
    # added after /1 shipped: left out of the JSON when unset (no scanner), so it reads as before
    lasers: list[LaserMsg] | msgspec.UnsetType = msgspec.UNSET


# a spec's fields as they were named before they carried their units (still in older recordings): old -> new
RENAMED_SPEC_FIELDS = {
    "width": "width_m",
    "height": "height_m",
    "x": "x_m",
    "y": "y_m",
    "dir": "dir_deg",
    "max_speed": "max_speed_mps",
    "beacon_height": "beacon_height_m",
}
RENAMED_SENSOR_FIELDS = {"x": "x_m", "y": "y_m"}  # each of ir_sensors and lasers


def _renamed(doc: dict[str, Any], names: dict[str, str]) -> dict[str, Any]:
    """``doc`` with its old names as the new ones (a name whose new one is there too stays: refused)."""
    return {names[k] if k in names and names[k] not in doc else k: v for k, v in doc.items()}


def upgrade_spec_names(spec: Any) -> Any:
    """A spec as it was written before its fields carried their units (a decoded JSON object), renamed.

    Args:
        spec: The spec's JSON object (anything else is returned as it is, to be refused).

    Returns:
        The object with the new names.
    """
    if not isinstance(spec, dict):
        return spec
    out = _renamed(spec, RENAMED_SPEC_FIELDS)
    for kind in ("ir_sensors", "lasers"):
        if isinstance(out.get(kind), list):
            out[kind] = [_renamed(s, RENAMED_SENSOR_FIELDS) if isinstance(s, dict) else s for s in out[kind]]
    return out


class RegisterRequest(Message, frozen=True, kw_only=True):
    """Asks the world for a robot (``world/register`` query payload)."""

    schema: ClassVar[str] = "iw.RegisterRequest/1"
    spec: RobotSpecMsg
    agent: str = ""  # the liveliness name of the agent process that drives it
    request_id: str = ""  # the same id asked again gets the same answer (retries are safe)

    @staticmethod
    def upgrade(doc: dict[str, Any]) -> dict[str, Any]:
        """A request written before the spec's fields carried their units, renamed."""
        return {**doc, "spec": upgrade_spec_names(doc.get("spec"))} if "spec" in doc else doc


class RegisterReply(Message, frozen=True, kw_only=True):
    """The world's answer: the accepted spec with id and start pose, or a refusal and why."""

    schema: ClassVar[str] = "iw.RegisterReply/1"
    ok: bool
    robot_id: RobotId = 0
    spec: RobotSpecMsg | None = None
    reason: str = ""

    @staticmethod
    def upgrade(doc: dict[str, Any]) -> dict[str, Any]:
        """A reply written before the spec's fields carried their units, renamed."""
        return {**doc, "spec": upgrade_spec_names(doc.get("spec"))} if "spec" in doc else doc


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
    # added after /1 shipped: left out of the JSON when unset, so an older description reads as
    # before. One per robot, in the order of ``robots``: the liveliness name of the agent driving
    # it ("" for none), so a late joiner knows it without having seen its ``registered`` event.
    agents: list[str] | msgspec.UnsetType = msgspec.UNSET
    # added later too: an HMAC of the rest under the key iwz run gave its world (nodes/world_seal.py)
    seal: Annotated[str, msgspec.Meta(max_length=64)] | msgspec.UnsetType = msgspec.UNSET

    @staticmethod
    def upgrade(doc: dict[str, Any]) -> dict[str, Any]:
        """A description written before its robots' spec fields carried their units, renamed."""
        robots = doc.get("robots")
        return {**doc, "robots": [upgrade_spec_names(r) for r in robots]} if isinstance(robots, list) else doc

    def __post_init__(self) -> None:
        """Refuses a roster that names a robot twice, or agents that are not one per robot."""
        if len(self.robots) > 1:
            _unique([r.id for r in self.robots], "robots")
        if isinstance(self.agents, list):
            _lengths(len(self.robots), "robots", {"agents": self.agents})


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
