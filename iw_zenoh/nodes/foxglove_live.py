"""Foxglove live: a running simulation served over the Foxglove WebSocket protocol.

Through the ``foxglove-sdk`` package: its server speaks the protocol (subprotocol
``foxglove.sdk.v1``, the ``foxglove.websocket.v1`` protocol renamed) on a loopback port of its own,
behind :mod:`iw_zenoh.nodes.foxglove_gate`, which serves both names on the port users connect to;
and this module offers it the same channels a recording has (:mod:`iw_zenoh.record.channels`: one
per Zenoh key with its JSON Schema, and the derived ``/foxglove/scene``, ``/foxglove/tf`` and laser
scans in Foxglove's own protobuf types), each declared when its first message arrives. The world's
description (``world/info`` and the walls it draws) is sent once (:class:`InfoLatch`: the same
description again is not resent, another description replaces it, so a forged one cannot block the
world's own; with the run's seal key only the world's sealed ones), and again to a client when it
subscribes to it. Foxglove or Lichtblick, connected to ``ws://HOST:PORT``, sees the scene and the
state and gets a scene update every tick. Loopback only unless another host is given.

:func:`start_foxglove_live` is self-contained (a process that has a bus starts it: ``iwz
foxglove``, the viewer); ``iwz foxglove`` is the role command.
"""

from __future__ import annotations

import argparse
import logging
import threading
import time
from collections.abc import Sequence

import foxglove
import msgspec
from foxglove.websocket import ChannelView, Client, ServerListener

from iw_zenoh import keys
from iw_zenoh.bus import Asked, Delivery, Handle, Inbox
from iw_zenoh.bus.publishers import Publishers
from iw_zenoh.errors import IwError
from iw_zenoh.messages import WorldInfo, decode
from iw_zenoh.nodes.foxglove_gate import FoxgloveGate
from iw_zenoh.nodes.world_seal import seal_key, sealed
from iw_zenoh.process.runtime import NodeIO, Process, start_role
from iw_zenoh.record.channels import ChannelSpec, Derivation, key_channel
from iw_zenoh.record.foxglove import SCENE_TOPIC, TF_TOPIC
from iw_zenoh.viewer.guard import is_loopback

__all__ = ["DEFAULT_PORT", "FoxgloveLive", "InfoLatch", "main", "start_foxglove_live"]

logger = logging.getLogger(__name__)

DEFAULT_HOST = "127.0.0.1"  # loopback only: a viewer on another machine is asked for with --host
DEFAULT_PORT = 8765  # Foxglove's own default for a WebSocket data source
BACKLOG = 20_000  # deliveries kept when the server falls behind (the newest; a viewer may skip)
CHANNELS_KEPT = 4096  # channels (a Zenoh key each, a laser per robot) before the quiet ones are closed
POLL_S = 0.1  # the loop looks at its stop flag at least this often
INFO_TIMEOUT_S = 2.0


class _Revision(msgspec.Struct):
    revision: int = -1


_REVISION = msgspec.json.Decoder(_Revision)  # a state's revision alone, without decoding its arrays


class InfoLatch:
    """Which of the world's descriptions (``world/info``, published or answered) are served.

    With the key ``iwz run`` gave its world (:mod:`iw_zenoh.nodes.world_seal`; a process that holds
    it), only descriptions sealed under it: the world's own. Without it (the usual case: only the
    world is given the key), any description unless it is the one served last but for its tick
    and seal (the world's publication and its answer to the query differ only there): so the newest
    is served, and a forged one carrying the current revision is replaced by the world's own when
    that comes, instead of shutting it out for the whole revision.
    """

    def __init__(self, key: bytes | None) -> None:
        self._key = key
        self._last: WorldInfo | bytes | None = None
        self.refused = 0  # descriptions not sealed by the world (with a key only)

    def take(self, data: bytes) -> bool:
        """Whether ``data`` (a ``world/info`` payload) is served and becomes the latched one."""
        try:
            info: WorldInfo | None = decode(data, WorldInfo)
        except IwError:
            info = None
        if self._key is not None and (info is None or not sealed(info, self._key)):
            self.refused += 1
            if self.refused == 1:
                logger.warning("a world description not sealed by this run's world was not served")
            return False
        same: WorldInfo | bytes = (
            data if info is None else msgspec.structs.replace(info, tick=0, sim_time_ns=0, seal=msgspec.UNSET)
        )
        if same == self._last:
            return False
        self._last = same
        return True


class _Listener(ServerListener):
    """Notes which channels a client subscribed to, so that their latched message (the world's
    description, the walls) is sent for it (foxglove-sdk calls this from its own thread: it only
    notes the topic). foxglove-sdk's Python API names no client's sink, so the message goes to
    every subscriber of that channel: a client already there gets it again when another joins."""

    def __init__(self, wake: threading.Event) -> None:
        self._topics: set[str] = set()
        self._lock = threading.Lock()
        self._wake = wake

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        """A client subscribed to a channel."""
        with self._lock:
            self._topics.add(channel.topic)
        self._wake.set()

    def take(self) -> set[str]:
        """The topics subscribed to since the last call."""
        with self._lock:
            topics, self._topics = self._topics, set()
        return topics


class _Channel:
    """A channel kept like a publisher: given up (closed, unadvertised) once its key is quiet."""

    def __init__(self, channel: foxglove.Channel) -> None:
        self.channel = channel

    def undeclare(self) -> None:
        """Closes it."""
        self.channel.close()


class FoxgloveLive:
    """A Foxglove WebSocket server fed from the bus (see :func:`start_foxglove_live`).

    Attributes:
        port: The port it listens on (the one asked for, or the one given for port 0).
        host: The address it listens on.
    """

    def __init__(self, io: NodeIO, host: str, port: int, allow_origins: Sequence[str] = ()) -> None:
        self.io = io
        self.host = host
        self._ctx = foxglove.Context()
        self._wake = threading.Event()
        self._listener = _Listener(self._wake)
        # foxglove-sdk's server on a loopback port of its own; the gate serves both subprotocols
        self._server = foxglove.start_server(
            name=f"iw-zenoh {io.sim}", host="127.0.0.1", port=0, context=self._ctx, server_listener=self._listener
        )
        try:
            self._gate = FoxgloveGate(host, port, self._server.port, allow_origins)
        except OSError as e:
            self._server.stop()
            raise RuntimeError(e.strerror or str(e)) from None
        self.port: int = self._gate.port
        # a channel per key and per robot's laser: those of robots that left are closed once quiet
        self._channels: Publishers[_Channel] = Publishers(self._declare, CHANNELS_KEPT)
        self._declaring: ChannelSpec | None = None  # the spec of the channel being fetched
        self._derivation = Derivation()
        # topic -> what a late subscriber needs (info, walls): its channel's spec and last message
        self._latched: dict[str, tuple[ChannelSpec, bytes]] = {}
        self._info_revision = -1
        self._info = InfoLatch(seal_key())  # which world descriptions are served
        self._asked: Asked | None = None
        self._taken = 0  # answers to it served so far
        self._stop = threading.Event()
        self._inbox = Inbox(maxlen=BACKLOG, wake=self._wake)
        self._sub: Handle = io.bus.subscribe(keys.everything(io.sim), self._inbox)
        self._thread = threading.Thread(target=self._loop, name="foxglove-live", daemon=True)
        self._thread.start()

    def _channel(self, spec: ChannelSpec) -> foxglove.Channel:
        """The channel of ``spec``'s topic, advertised now if it has none (the loop's thread only)."""
        self._declaring = spec
        return self._channels.get(spec.topic).channel

    def _declare(self, topic: str) -> _Channel:
        """Advertises the channel of ``topic``: the spec being fetched, or the Zenoh key's."""
        spec = self._declaring if self._declaring is not None and self._declaring.topic == topic else key_channel(topic)
        schema = (
            foxglove.Schema(name=spec.schema_name, encoding=spec.schema_encoding, data=spec.schema)
            if spec.schema_name
            else None
        )
        return _Channel(
            foxglove.Channel(
                spec.topic, schema=schema, message_encoding=spec.encoding, context=self._ctx, metadata=spec.metadata
            )
        )

    def _drawing(self) -> bool:
        """Whether a client watches the scene (drawing every state costs; the world's description
        is always taken, so the first scene a client gets is whole)."""
        scene, tf = self._channels.peek(SCENE_TOPIC), self._channels.peek(TF_TOPIC)
        return scene is None or tf is None or scene.channel.has_sinks() or tf.channel.has_sinks()  # then on demand

    def _publish(self, delivery: Delivery) -> None:
        key, data, t = delivery
        kind = keys.topic_kind(key)
        if kind == "info":
            if not self._info.take(data):
                return  # the same description again (published and asked for), or not the world's
            self._latched[key] = (key_channel(key), data)
        self._channels.get(key).channel.log(data, log_time=t)  # declared from key_channel(key)
        if kind == "info" or (kind in ("state", "sensors") and self._drawing()):
            for spec, payload in self._derivation.derive(key, data):
                self._channel(spec).log(payload, log_time=t)
                if kind == "info":
                    self._latched[spec.topic] = (spec, payload)  # the walls, drawn once per revision
        if kind == "state":
            self._want_info(data)

    def _want_info(self, data: bytes) -> None:
        """Asks the world for its description when a state's revision is newer than the last one
        seen (a server started after the world has heard no ``world/info`` yet)."""
        try:
            rev = _REVISION.decode(data).revision
        except msgspec.DecodeError:
            return
        if rev != self._info_revision and (self._asked is None or self._asked.answered()):
            self._info_revision = rev
            self._ask_info()

    def _ask_info(self) -> None:
        self._asked, self._taken = self.io.bus.ask(keys.info(self.io.sim), timeout_s=INFO_TIMEOUT_S), 0

    def _take_info_answer(self) -> None:
        """Serves the world's answers to the last info query as if they came on ``world/info``."""
        if self._asked is None:
            return
        replies = self._asked.replies[self._taken :]  # appended by the network's thread
        self._taken += len(replies)
        for data in replies:
            self._publish((keys.info(self.io.sim), data, time.time_ns()))

    def _loop(self) -> None:
        self._ask_info()
        while not self._stop.is_set():
            self._wake.wait(POLL_S)
            self._wake.clear()
            self._take_info_answer()
            for d in self._inbox.drain():
                try:
                    self._publish(d)
                except Exception:  # one bad message never stops the server
                    logger.exception("could not serve a message on %s", d[0])
            for topic in self._listener.take():  # a client subscribed: its latched message, once
                latched = self._latched.get(topic)
                if latched is not None:
                    self._channel(latched[0]).log(latched[1], log_time=time.time_ns())

    def close(self) -> None:
        """Stops serving: the loop, the subscription, the server (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._wake.set()
        self._thread.join(5)
        try:
            self._sub.undeclare()
        except Exception:  # the session may be closing already
            logger.debug("undeclare failed", exc_info=True)
        self._gate.close()
        self._server.stop()


def start_foxglove_live(
    io: NodeIO, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT, allow_origins: Sequence[str] = ()
) -> FoxgloveLive:
    """Serves the simulation ``io`` belongs to over the Foxglove WebSocket protocol.

    Args:
        io: The process's handle on the bus (its simulation is the one served).
        host: The address to listen on (default loopback only; ``0.0.0.0`` for every interface).
        port: The TCP port (0: any free one, then read ``.port``).
        allow_origins: Web pages' origins let in beside Foxglove's and Lichtblick's apps and
            loopback pages (:mod:`iw_zenoh.nodes.foxglove_gate`).

    Returns:
        The running server; ``close()`` stops it.

    Raises:
        RuntimeError: The port cannot be bound (foxglove-sdk's error, with its reason).
    """
    return FoxgloveLive(io, host, port, allow_origins)


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--host", default=DEFAULT_HOST, help=f"address to listen on (default {DEFAULT_HOST}: this machine only)"
    )
    p.add_argument("--port", type=int, default=DEFAULT_PORT, help=f"TCP port (default {DEFAULT_PORT}; 0: any free)")
    p.add_argument(
        "--allow-origin",
        action="append",
        default=[],
        metavar="ORIGIN",
        help="also let web pages of ORIGIN read the run (e.g. https://studio.example; repeatable); "
        "Foxglove's and Lichtblick's apps and pages on this machine's loopback names get in without it",
    )


def _check(args: argparse.Namespace) -> argparse.Namespace:
    if not 0 <= args.port <= 65535:
        raise IwError(f"--port {args.port} is no TCP port: give 0..65535 (0: any free port)")
    return args


def _run(proc: Process, _args: argparse.Namespace) -> int:
    args = proc.args
    try:
        live = start_foxglove_live(proc.io, args.host, args.port, args.allow_origin)
    except RuntimeError as e:
        print(f"iwz foxglove: cannot listen on {args.host}:{args.port}: {e}. Is the port taken? Try --port", flush=True)
        return 2
    print(f"iwz foxglove: serving iw/{proc.sim}/** on ws://{args.host}:{live.port}", flush=True)
    if not is_loopback(args.host):
        print(
            f"iwz foxglove: WARNING: {args.host} is open to the network with no key: anyone there can watch the run "
            "(read-only: Foxglove cannot steer it); --host 127.0.0.1 keeps it on this machine",
            flush=True,
        )
    try:
        while not proc.io.stop.is_set():
            proc.io.stop.wait(0.5)
    finally:
        live.close()
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz foxglove``."""
    return start_role(
        argv,
        role="viewer",
        prog="iwz foxglove",
        name=lambda _args: "foxglove",
        description=(
            "Serve a running simulation to Foxglove or Lichtblick over the Foxglove WebSocket protocol "
            "(subprotocols foxglove.sdk.v1 and foxglove.websocket.v1): "
            "the same channels and schemas as a recording (every key, /foxglove/scene, /foxglove/tf, lasers)."
        ),
        epilog=(
            "Examples (then open ws://127.0.0.1:8765 in Foxglove: Open connection, Foxglove WebSocket):\n"
            "  iwz foxglove\n"
            "  iwz foxglove --sim demo --port 8766\n"
            "  iwz foxglove --host 0.0.0.0 --connect tcp/10.0.0.5:7447    (a viewer on another machine)\n"
            "  iwz foxglove --allow-origin https://lichtblick.example     (a self-hosted web app's pages)"
        ),
        arguments=_arguments,
        prepare=_check,  # before joining the bus
        run=_run,
    )
