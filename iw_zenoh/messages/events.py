"""Control of the world, and events: their kinds, each kind's typed payload, how one is made
and read."""

from __future__ import annotations

import enum
from typing import Annotated, Any, ClassVar, Literal, TypeVar, overload

import msgspec

from iw_zenoh.errors import DecodeError
from iw_zenoh.messages.wire import INT64_MAX, Int64, Message, NonNeg, RobotId
from iw_zenoh.messages.world import Obstacle

# --- control and events -----------------------------------------------------------------------


# the world's controls a viewer's page may send as they are (PageCommand), as well as iwz ctl
WorldCommand = Literal[
    "start",
    "pause",
    "step",
    "stop",
    "remove",
    "add_obstacle",
    "move_obstacle",
    "remove_obstacle",
]


class Control(Message, frozen=True, kw_only=True):
    """A command to the world."""

    schema: ClassVar[str] = "iw.Control/1"
    command: Literal[WorldCommand, "seek", "estop", "clear"]
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


class BadMessageData(EventData, frozen=True, kw_only=True, omit_defaults=True):
    """How many refused messages a ``bad-message`` event stands for (one per key and reason a
    second is reported; ``{}``: one)."""

    count: Annotated[int, msgspec.Meta(ge=1, le=INT64_MAX)] = 1


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
    late: NonNeg = 0  # heard after the Measures of their tick went (legacy bridge)


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
    EventKind.BAD_MESSAGE: BadMessageData,
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
    expected = EVENT_PAYLOADS[kind]
    data = (NoData() if expected is not BadMessageData else BadMessageData()) if payload is None else payload
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
