"""Where the viewer's page gets the world from: a live simulation on the bus (its batched keys,
never one subscription per robot), or a recording played in this process with a timeline.

A source's :meth:`poll` hands every message that came in to the :class:`~iw_zenoh.viewer.feed.Feed`
and returns what the pages must be told; :meth:`command` carries out what a page asks.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import Protocol, get_args

import msgspec

from iw_zenoh import keys
from iw_zenoh.bus import Asked, Bus, Delivery, Handle, Inbox, PendingQuery, QueryInbox
from iw_zenoh.errors import IwError
from iw_zenoh.messages import (
    Control,
    Event,
    Message,
    RadioBatch,
    SensorBatch,
    SensorReading,
    Tick,
    WorldInfo,
    WorldState,
    decode,
    encode,
)
from iw_zenoh.messages.events import WorldCommand
from iw_zenoh.messages.page import PageCommand, PageDriveInput, PageMessage, PageTimeline, TimelineMark
from iw_zenoh.record.incidents import find_incidents
from iw_zenoh.record.reader import open_recording
from iw_zenoh.record.replay import Player, ReplayOptions
from iw_zenoh.viewer.drive import DriveGrant, Drives, decode_state, relay
from iw_zenoh.viewer.feed import Feed

__all__ = ["LiveSource", "LocalBus", "ReplaySource", "Source"]

logger = logging.getLogger(__name__)

WORLD_CONTROLS: tuple[str, ...] = get_args(WorldCommand)  # the page commands that go to the world as they are
TIMELINE_EVERY_NS = 200_000_000  # a playing replay's position is told the pages this often
# a live page shows the present: a viewer behind keeps the newest deliveries of all its keys,
# about a minute of a busy run (a state, a tick, a batch per shard, radio and events each tick)
LIVE_KEPT = 4096


class Source(Protocol):
    """What feeds the pages."""

    live: bool
    sim: str

    def poll(self, feed: Feed, wall_ns: int) -> list[PageMessage]:
        """Hands everything that came in to ``feed``; what the pages must be told."""

    def command(self, cmd: PageCommand) -> str:
        """Carries out a page's command; why it cannot be done ("" when done)."""

    def drive(self, robot_id: int, driver: str, d: PageDriveInput) -> str:
        """Relays a page's driving of chair ``robot_id``; why it cannot ("" when relayed)."""

    def extra(self) -> list[PageMessage]:
        """What a page that joins needs besides the feed's snapshot."""

    def close(self) -> None:
        """Stops it."""


def _decode(d: Delivery, kind: type[Message]) -> Message | None:
    try:
        return decode(d[1], kind)
    except IwError as e:
        logger.warning("dropped a bad message on %s: %s", d[0], e)
        return None


def _feed(feed: Feed, d: Delivery, wall_ns: int) -> list[PageMessage]:
    """One delivery into the feed, by the kind of its key."""
    kind = keys.topic_kind(d[0])
    if kind == "state":
        st = _decode(d, WorldState)
        return feed.on_state(st, wall_ns, sent_ms=time.time() * 1e3) if isinstance(st, WorldState) else []
    if kind == "sensor_batch":
        b = _decode(d, SensorBatch)
        return feed.on_sensors(b) if isinstance(b, SensorBatch) else []
    if kind == "sensors":  # a recording without batches (a live viewer reads only the batches)
        one = _decode(d, SensorReading)
        return feed.on_readings(one.tick, [one]) if isinstance(one, SensorReading) else []
    if kind == "radio":
        r = _decode(d, RadioBatch)
        return feed.on_radio(r) if isinstance(r, RadioBatch) else []
    if kind == "event":
        e = _decode(d, Event)
        return feed.on_event(e) if isinstance(e, Event) else []
    if kind == "tick":
        t = _decode(d, Tick)
        return feed.on_tick(t, wall_ns) if isinstance(t, Tick) else []
    if kind == "info":
        i = _decode(d, WorldInfo)
        return feed.on_info(i) if isinstance(i, WorldInfo) else []
    return []


def _latest_states(ds: list[Delivery]) -> list[Delivery]:
    """Every delivery but the states before the last one (a page behind skips to the newest pose)."""
    last = max((i for i, d in enumerate(ds) if keys.topic_kind(d[0]) == "state"), default=-1)
    return [d for i, d in enumerate(ds) if i >= last or keys.topic_kind(d[0]) != "state"]


class LiveSource:
    """A live simulation: the world's batched keys, and control published to its world.

    Args:
        bus: The bus.
        sim: The simulation name.
        wake: Set whenever something arrives.
        grant: The chairs its pages may drive (default: any).
    """

    live = True

    def __init__(self, bus: Bus, sim: str, wake: threading.Event, grant: DriveGrant | None = None) -> None:
        self.bus = bus
        self.sim = sim
        self.grant = grant or DriveGrant(None)
        self.drives = Drives()
        self.inbox = Inbox(maxlen=LIVE_KEPT, wake=wake)
        for key in (
            keys.info(sim),
            keys.tick(sim),
            keys.state(sim),
            keys.all_sensor_batches(sim),
            keys.radio(sim),
            keys.all_events(sim),
            keys.all_driving(sim),
        ):
            bus.subscribe(key, self.inbox)
        self._asked: Asked | None = bus.ask(keys.info(sim))

    def poll(self, feed: Feed, wall_ns: int) -> list[PageMessage]:
        """Hands the new messages to ``feed``, asking the world again when a state is newer."""
        out: list[PageMessage] = []
        if self._asked is not None and self._asked.answered():
            for data in self._asked.replies:
                try:
                    out += feed.on_info(decode(data, WorldInfo))
                except IwError as e:
                    logger.warning("world/info answer refused: %s", e)
            self._asked = None
        ids = feed.ids
        for d in _latest_states(self.inbox.drain()):
            kind = keys.topic_kind(d[0])
            if kind == "driving":
                got = decode_state(d[0], d[1])
                out += self.drives.on_state(*got) if got is not None else []
                continue
            if kind == "state" and self._asked is None:
                st = _decode(d, WorldState)
                if isinstance(st, WorldState) and feed.needs_info(st.revision):
                    self._asked = self.bus.ask(keys.info(self.sim))
            out += _feed(feed, d, wall_ns)
        return out + (self.drives.keep(feed.ids) if feed.ids != ids else [])

    def command(self, cmd: PageCommand) -> str:
        """Publishes a world control on the simulation's control key."""
        if cmd.cmd not in WORLD_CONTROLS:
            return f"{cmd.cmd!r} is for replays; a live world cannot go back in time or change its pace"
        if cmd.cmd.endswith("_obstacle") and cmd.obstacle is None:
            return f"{cmd.cmd} needs an obstacle: {{name, x0, y0, x1, y1}}"
        c = msgspec.convert(
            {"command": cmd.cmd, "robot_id": cmd.robot_id, "obstacle": cmd.obstacle, "steps": cmd.steps},
            Control,
            from_attributes=True,
        )
        self.bus.publish(keys.control(self.sim), encode(c))
        return ""

    def drive(self, robot_id: int, driver: str, d: PageDriveInput) -> str:
        """Publishes a page's input on the chair's drive key, if this viewer may drive it."""
        if why := self.grant.refusal(robot_id):
            return why
        relay(self.bus, self.sim, robot_id, driver, d)
        return ""

    def extra(self) -> list[PageMessage]:
        """Every chair's drive state (a live page has no timeline)."""
        return self.drives.snapshot()

    def close(self) -> None:
        """Nothing to stop (the bus is the process's)."""


class _NoQueries:
    def poll(self) -> list[PendingQuery]:
        return []

    def undeclare(self) -> None:
        """Nothing to stop."""


class _Nothing:
    def undeclare(self) -> None:
        """Nothing to stop."""


class LocalBus:
    """A bus inside this process, for a recording played to the page: what is published goes to
    the subscriber of that very key, or else into ``out``."""

    def __init__(self, out: Inbox) -> None:
        self.out = out
        self._subs: dict[str, Inbox] = {}

    def publish(self, key: str, data: bytes) -> None:
        """Delivers to the subscriber of ``key``, or into ``out``."""
        sub = self._subs.get(key)  # (an empty inbox is falsy: no `or` here)
        (self.out if sub is None else sub).put((key, data, time.time_ns()))

    def subscribe(self, key_expr: str, inbox: Inbox, *, ordered: bool = False) -> Handle:
        """Subscribes one exact key."""
        self._subs[key_expr] = inbox
        return _Nothing()

    def serve(self, key: str) -> QueryInbox:
        """Nobody asks here."""
        return _NoQueries()

    def query(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> list[bytes]:
        """Nobody answers here."""
        return []

    def ask(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> Asked:
        """Nobody answers here."""
        asked = Asked()
        asked.done.set()
        return asked

    def token(self, key: str) -> Handle:
        """Nobody watches here."""
        return _Nothing()

    def watch_alive(self, key_expr: str, on_change: Callable[[str, bool], None]) -> Handle:
        """Nobody is alive here."""
        return _Nothing()

    def close(self) -> None:
        """Nothing to close."""


class ReplaySource:
    """A recording played in this process, steered from the page's timeline.

    Args:
        path: The recording (any of its parts).
        wake: Set whenever something is played.
        rate: The speed to play at once started.
        paused: Start paused at the recording's first state, shown (a page's start plays it);
            False: play at once.

    Raises:
        RecordingError: The file cannot be read.
        IwError: It holds no world state.
    """

    live = False

    def __init__(self, path: Path, wake: threading.Event, *, rate: float = 1.0, paused: bool = True) -> None:
        self._files = ExitStack()
        try:
            reader = self._files.enter_context(open_recording(path))
            self.marks = [
                TimelineMark(t_ns=int(i.t * 1e9), kind=i.kind, what=i.what, robots=list(i.robots))
                for i in find_incidents(reader)
            ]
            self.inbox = Inbox(wake=wake)
            self.player = Player(reader, LocalBus(self.inbox), ReplayOptions(rate=rate, hold=True, paused=paused))
            self.player.steps = 1 if paused else 0  # paused on the first state, which is shown
        except BaseException:
            self._files.close()
            raise
        assert self.player.sim is not None
        self.sim = self.player.sim
        self._control = keys.control(self.player.target)
        self._told: tuple[int, PageTimeline] | None = None
        self._thread = threading.Thread(target=self.player.run, name="replay", daemon=True)
        self._thread.start()

    def timeline(self) -> PageTimeline:
        """Where the replay is."""
        p = self.player
        return PageTimeline(
            start_ns=p.sims[0] if p.sims else 0,
            end_ns=p.sims[-1] if p.sims else 0,
            position_ns=p.position_ns,
            playing=not p.paused and not p.at_end,
            rate=p.opts.rate,
            marks=self.marks,
        )

    def poll(self, feed: Feed, wall_ns: int) -> list[PageMessage]:
        """Hands what was played to ``feed``; the timeline when it moved."""
        out: list[PageMessage] = []
        for d in _latest_states(self.inbox.drain()):
            if keys.topic_kind(d[0]) == "state":
                st = _decode(d, WorldState)
                info = self.player.last_info
                if isinstance(st, WorldState) and feed.needs_info(st.revision) and info is not None:
                    out += _feed(feed, (keys.info(self.sim), info, d[2]), wall_ns)
            out += _feed(feed, d, wall_ns)
        t = self.timeline()
        last = self._told
        if (
            last is None
            or (t.playing, t.rate) != (last[1].playing, last[1].rate)
            or (t.position_ns != last[1].position_ns and wall_ns - last[0] >= TIMELINE_EVERY_NS)
        ):
            self._told = (wall_ns, t)
            out.append(msgspec.structs.replace(t, marks=None))  # the marks were sent on joining
        return out

    def command(self, cmd: PageCommand) -> str:
        """Play (``start``), pause, step, seek and rate; a recording cannot be changed."""
        c = cmd.cmd
        if c == "rate":
            self.player.set_rate(cmd.rate)
            return ""
        if c == "seek":
            self._send(Control(command="seek", at_ns=cmd.at_ns))
            if self.player.paused:  # show the moment sought, and stay paused there
                self._send(Control(command="step", steps=1))
            return ""
        if c in ("start", "pause", "step"):
            self._send(
                Control(command="step" if c == "step" else "start" if c == "start" else "pause", steps=cmd.steps)
            )
            return ""
        return f"{c!r} changes a live world; this is a recording (play, pause, step, seek, rate)"

    def _send(self, c: Control) -> None:
        self.player.control.put((self._control, encode(c), time.time_ns()))
        self.player.wake.set()

    def drive(self, robot_id: int, driver: str, d: PageDriveInput) -> str:
        """Nobody drives a recording."""
        return "this is a recording: its chairs drove as they were recorded; drive a chair in a live run"

    def extra(self) -> list[PageMessage]:
        """The timeline, marks included."""
        return [self.timeline()]

    def close(self) -> None:
        """Stops the player and closes the file."""
        self.player.stop.set()
        self.player.wake.set()
        self._thread.join(30)
        if self._thread.is_alive():  # stuck in a read: closing the file under it would fail it
            logger.warning("the replay's player did not stop within 30 s; its file is left to the process's exit")
            return
        self._files.close()
