"""The viewer's WebSocket messages (``iwz view``): what its server sends the page, and the
commands the page sends back.

Every server message is a JSON object tagged by ``type``. Static things (walls, obstacles,
robots' outlines and sensors) travel in a :class:`PageScene`, sent again only when the world's
revision changes; each tick a :class:`PageFrame` carries the poses (the robot ids only when the
roster changed), :class:`PageReadings` the proximity readings that changed, :class:`PageScans`
the laser scans that changed, :class:`PageHeard` the radio messages heard and :class:`PageEvent`
each event, :class:`PageDrive` a chair's drive state (the chairs whose agent accepts a driver).
``docs/viewer.md`` draws the whole exchange; ``docs/driving.md`` the driving.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec

from iw_zenoh.messages.drive import DriveState
from iw_zenoh.messages.events import WorldCommand
from iw_zenoh.messages.wire import NonNeg, RobotId
from iw_zenoh.messages.world import Obstacle

__all__ = [
    "PageCommand",
    "PageDrive",
    "PageDriveInput",
    "PageError",
    "PageEvent",
    "PageFrame",
    "PageHeard",
    "PageHello",
    "PageLaser",
    "PageMessage",
    "PageReading",
    "PageReadings",
    "PageRobot",
    "PageScans",
    "PageScene",
    "PageSensor",
    "PageStatus",
    "PageTimeline",
    "PageWall",
    "TimelineMark",
]

Xy = tuple[float, float]


class _Out(msgspec.Struct, frozen=True, kw_only=True, tag_field="type"):
    """Base of what the server sends (tagged by ``type``)."""


class PageHello(_Out, frozen=True, kw_only=True, tag="hello"):
    """The first message on a connection: live or replay, which simulation."""

    live: bool
    sim: str
    version: str = ""
    steer: bool = True  # False: this page may only watch (its address has the watch key)
    driver: str = ""  # this page's name as a driver (a chair's drive state names who drives it)


class PageSensor(msgspec.Struct, frozen=True, kw_only=True):
    """A proximity cone in the robot's frame (metres, degrees)."""

    id: int
    x: float
    y: float
    angle_deg: float
    cone_deg: float
    range_m: float


class PageLaser(msgspec.Struct, frozen=True, kw_only=True):
    """A laser scanner as drawn: mounted at (``x``, ``y``) in the robot's frame, its ``beams``
    spread evenly over ``fov_deg`` centred on ``angle_deg`` (the first at ``angle - fov/2``; one
    beam looks along ``angle_deg``), reading up to ``range_m``."""

    id: int
    x: float
    y: float
    angle_deg: float
    fov_deg: float
    beams: int
    range_m: float


class PageRobot(msgspec.Struct, frozen=True, kw_only=True):
    """A robot as drawn: its outline in its own frame (origin at the centre of movement, x along
    the heading), its sensors and laser scanners, its spec, and the agent that drives it (empty:
    not known)."""

    id: int
    name: str
    type: str
    outline: list[Xy]
    sensors: list[PageSensor]
    spec: dict[str, Any]
    agent: str = ""
    lasers: list[PageLaser] = []


class PageWall(msgspec.Struct, frozen=True, kw_only=True):
    """A wall polygon and its height (m)."""

    corners: list[Xy]
    height: float


class PageScene(_Out, frozen=True, kw_only=True, tag="scene"):
    """Everything static of one revision of the world."""

    revision: int
    name: str
    width: float
    height: float
    walls: list[PageWall]
    obstacles: list[Obstacle]
    beacons: list[tuple[float, float, float]]
    targets: list[tuple[float, float, float]]
    robots: list[PageRobot]
    period_ns: int


class PageFrame(_Out, frozen=True, kw_only=True, tag="frame"):
    """One tick's poses: ``x``, ``y`` (m), ``heading`` (rad) in the order of ``ids`` (sent only
    when the roster changed: ``None`` means the last ids sent); ``state`` one letter per robot:
    ``d`` driving, ``h`` held, ``w`` stopped by the watchdog, ``c`` collided."""

    tick: int
    t_ns: int
    ids: list[int] | None = None
    x: list[float]
    y: list[float]
    heading: list[float]
    state: str
    held_reason: str = ""
    sent_ms: float = 0.0  # the server's wall clock when it sent this (ms since the epoch)
    tick_wall_ms: float = 0.0  # the world's wall clock when it began this tick (ms since the epoch; 0: not said)


class PageStatus(_Out, frozen=True, kw_only=True, tag="status"):
    """The clock: tick, simulation time, real-time factor (simulation seconds per wall second)."""

    tick: int
    t_ns: int
    mode: str
    running: bool
    rtf: float
    period_ns: int


class PageReadings(_Out, frozen=True, kw_only=True, tag="readings"):
    """Proximity readings that changed this tick: robot id (as text, a JSON key) to one distance
    per sensor of its :class:`PageSensor` list (``None``: nothing in range)."""

    tick: int
    prox: dict[str, list[float | None]]


class PageScans(_Out, frozen=True, kw_only=True, tag="scans"):
    """Laser scans that changed: robot id (as text, a JSON key) to one list of ranges per scanner
    of its :class:`PageLaser` list, first beam first (``None``: nothing within range)."""

    tick: int
    scans: dict[str, list[list[float | None]]]


class PageReading(_Out, frozen=True, kw_only=True, tag="reading"):
    """Everything known of one robot now (the answer to a ``reading`` command)."""

    robot_id: int
    reading: dict[str, Any] | None
    speed: float | None
    motors: tuple[float, float] | None
    pose: tuple[float, float, float] | None
    events: list[dict[str, Any]]


class PageHeard(_Out, frozen=True, kw_only=True, tag="heard"):
    """Radio messages heard this tick: ``[to, from, distance m, text]``."""

    tick: int
    messages: list[tuple[int, int, float, str]]


class PageEvent(_Out, frozen=True, kw_only=True, tag="event"):
    """An event, with where it happened when known (a collision's point, else the robot's pose)."""

    tick: int
    t_ns: int
    kind: str
    reason: str
    robot_id: int
    where: Xy | None = None


class TimelineMark(msgspec.Struct, frozen=True, kw_only=True):
    """An incident on the replay's timeline."""

    t_ns: int
    kind: str
    what: str
    robots: list[int] = []


class PageTimeline(_Out, frozen=True, kw_only=True, tag="timeline"):
    """A replay's timeline: its span, where it is, whether it plays, how fast, its incidents
    (``None``: the ones sent before)."""

    start_ns: int
    end_ns: int
    position_ns: int
    playing: bool
    rate: float
    marks: list[TimelineMark] | None = None


class PageDrive(_Out, frozen=True, kw_only=True, tag="drive"):
    """A chair's drive state as its agent publishes it (who drives, the command before and after
    the shared control, ...): sent on change; ``state`` ``None`` when its agent no longer tells it
    (the chair left). Only chairs whose agent accepts a driver have one (docs/driving.md)."""

    robot_id: int
    state: DriveState | None


class PageError(_Out, frozen=True, kw_only=True, tag="error"):
    """A command the server refused, and why (``drive_robot``: the chair a refused ``drive`` was for)."""

    error: str
    drive_robot: int | None = None


PageMessage = (
    PageHello
    | PageScene
    | PageFrame
    | PageStatus
    | PageReadings
    | PageScans
    | PageReading
    | PageHeard
    | PageEvent
    | PageTimeline
    | PageDrive
    | PageError
)


Unit = Annotated[float, msgspec.Meta(ge=-1.0, le=1.0)]


class PageDriveInput(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A ``drive`` command's input, relayed to the chair as an ``iw.DriveInput`` under this
    page's driver name: the stick (``x`` right, ``y`` forward, each -1..1), ``buttons`` (bit 0
    the dead-man held), the speed ``level`` 1..5, ``take`` (take the chair over), ``release``
    (leave it), ``goto`` (a point in metres for the chair's planner), ``assist`` (a new shared
    control level)."""

    seq: Annotated[int, msgspec.Meta(ge=0, le=2**31 - 1)] = 0
    x: Unit = 0.0
    y: Unit = 0.0
    buttons: Annotated[int, msgspec.Meta(ge=0, le=0xFFFF)] = 0
    level: Annotated[int, msgspec.Meta(ge=1, le=5)] = 1
    take: bool = False
    release: bool = False
    goto: tuple[float, float] | None = None
    assist: Literal["off", "safe", "assist"] | None = None


class PageCommand(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """What the page asks: a world control (``start`` ... ``remove_obstacle``), a robot's
    ``reading``, in a replay ``seek`` (``at_ns``) and ``rate``, or which laser scans it draws
    (``scans``: every robot's with ``scans="all"``, only robot ``robot_id``'s with
    ``scans="selected"``, no robot's with ``scans="none"``; every robot's until it says), or
    ``drive`` chair ``robot_id`` with ``drive`` (docs/driving.md)."""

    cmd: Literal[WorldCommand, "reading", "seek", "rate", "scans", "drive"]
    robot_id: RobotId = 0  # within 63 bits, as every id the world uses
    obstacle: Obstacle | None = None
    steps: Annotated[int, msgspec.Meta(ge=1, le=10_000)] = 1
    at_ns: NonNeg = 0
    rate: Annotated[float, msgspec.Meta(ge=0.0, le=1000.0)] = 1.0
    scans: Literal["all", "selected", "none"] = "all"
    drive: PageDriveInput | None = None
