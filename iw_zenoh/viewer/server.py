"""The viewer's web server: the page's static files (shipped in the package, nothing from a CDN)
and one WebSocket per page (aiohttp serves both from one asyncio loop).

A pump thread drains the source into the :class:`~iw_zenoh.viewer.feed.Feed` and encodes each
page message once; the loop hands it to every page. Laser scans go to each page only for the
robots it draws (its ``scans`` command, :class:`~iw_zenoh.viewer.feed.ScansWanted`), encoded once
per choice. A page that joins, or falls too far behind (:data:`MAX_BACKLOG` messages unsent), is
given the feed's snapshot and goes on from there. At most :data:`MAX_PAGES` pages are open at once
(each costs its queue and a share of every delivery): the next is refused with HTTP 503 and its
reason, and logged.

Every request to the page or its WebSocket passes :class:`~iw_zenoh.viewer.guard.Access` first (its
``Origin``, ``Host`` and key: HTTP 403 and why when refused), and every command
:func:`~iw_zenoh.viewer.guard.check_command` and the page's :class:`~iw_zenoh.viewer.guard.Rate`;
a command that fails on the pump is answered with an error to its page, and the pump goes on.

A page's ``drive`` commands (its own :class:`~iw_zenoh.viewer.guard.Rate`: a driving page sends
20 a second) are relayed to the chair under the page's driver name (``VIEWER#N``) at once, on the
loop that received them (not queued for the pump: a key's latency does not wait for the pump's
pass); when the socket of a page that drives is lost, the viewer releases its chair
(:mod:`iw_zenoh.viewer.drive`).
"""

from __future__ import annotations

import asyncio
import collections
import logging
import queue
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import msgspec
from aiohttp import WSMsgType, web

from iw_zenoh import __version__
from iw_zenoh.messages.page import PageCommand, PageDriveInput, PageError, PageHello, PageMessage, PageScans
from iw_zenoh.viewer.drive import driver_name
from iw_zenoh.viewer.feed import Feed, ScansWanted
from iw_zenoh.viewer.guard import Access, Rate, check_command
from iw_zenoh.viewer.sources import Source

__all__ = ["MAX_PAGES", "MODEL_SUFFIXES", "STATIC", "Client", "Pump", "Scans", "make_app", "model_files"]

logger = logging.getLogger(__name__)

STATIC = Path(__file__).resolve().parent / "static"
MAX_BACKLOG = 64  # messages waiting for one page; past that it is resynchronised from a snapshot
MAX_COMMAND_BYTES = 64 * 1024  # a page's command is a small JSON object
MAX_PAGES = 32  # pages open at once (iwz view --max-pages): a class watching one run, not a crowd
DRIVE_PER_S = 50.0  # a driving page's commands a second: its 20 Hz input, and one more at each key change
_ENCODER = msgspec.json.Encoder()
_COMMAND = msgspec.json.Decoder(PageCommand)


@dataclass(eq=False)
class Client:
    """One page: its socket, what waits to be sent to it, whether it has its snapshot, whose laser
    scans it draws."""

    ws: web.WebSocketResponse
    waiting: collections.deque[str] = field(default_factory=collections.deque)
    ready: asyncio.Event = field(default_factory=asyncio.Event)
    joined: bool = False
    closed: bool = False
    scans: ScansWanted = field(default_factory=ScansWanted)
    right: str = "steer"  # or "watch": what its address's key (or its being on loopback) lets it do
    rate: Rate = field(default_factory=Rate)
    driver: str = ""  # its name as a driver
    driving: int | None = None  # the chair it drives (sent input for and did not release)
    drive_rate: Rate = field(default_factory=lambda: Rate(per_s=DRIVE_PER_S, burst=DRIVE_PER_S))


class Scans:
    """Laser scans to hand out, encoded once for each page's choice of robots (on the server's loop).

    Args:
        msg: Every scan that changed.
    """

    def __init__(self, msg: PageScans) -> None:
        self.msg = msg
        self._encoded: dict[ScansWanted, str | None] = {}

    def for_page(self, wanted: ScansWanted) -> str | None:
        """The message for a page that draws ``wanted`` (``None``: nothing it draws changed)."""
        if wanted not in self._encoded:
            kept = wanted.keep(self.msg)
            self._encoded[wanted] = None if kept is None else _ENCODER.encode(kept).decode()
        return self._encoded[wanted]


Outgoing = str | Scans  # an encoded message for every page, or scans to encode per page


def _encoded(msgs: list[PageMessage]) -> list[Outgoing]:
    return [Scans(m) if isinstance(m, PageScans) else _ENCODER.encode(m).decode() for m in msgs]


class Pump(threading.Thread):
    """Drains the source into the feed and hands the pages what to show (its own thread).

    Args:
        source: Live or replay.
        feed: The page's view of the world.
        wake: Set by the source when something arrives.
        deliver: Called with ``(client or None for every page, encoded messages, is a snapshot)``.
    """

    def __init__(
        self,
        source: Source,
        feed: Feed,
        wake: threading.Event,
        deliver: collections.abc.Callable[[Client | None, list[Outgoing], bool], None],
    ) -> None:
        super().__init__(name="viewer-pump", daemon=True)
        self.source = source
        self.feed = feed
        self.wake = wake
        self.deliver = deliver
        self.stop = threading.Event()
        self.requests: queue.SimpleQueue[tuple[Client, PageCommand | None]] = queue.SimpleQueue()

    def ask(self, client: Client, cmd: PageCommand | None) -> None:
        """Queues a page's command (``None``: it joins and needs a snapshot)."""
        self.requests.put((client, cmd))
        self.wake.set()

    def run(self) -> None:
        """Until stopped: what came in to every page, and each page's requests answered."""
        while not self.stop.is_set():
            self.wake.wait(0.1)
            self.wake.clear()
            now = time.time_ns()
            try:
                out = self.source.poll(self.feed, now)
            except Exception:  # a source's fault must not stop the page
                logger.exception("the viewer's source failed")
                out = []
            if out:
                self.deliver(None, _encoded(out), False)
            while not self.requests.empty():
                client, cmd = self.requests.get()
                try:
                    answer = self._answer(client, cmd, now)
                except Exception as e:  # one page's command must not end the pump of every page
                    logger.exception("a page's command %r failed", cmd)
                    answer = [PageError(error=f"command failed: {type(e).__name__}: {str(e)[:200]}")]
                self.deliver(client, _encoded(answer), cmd is None)

    def _answer(self, client: Client, cmd: PageCommand | None, now: int) -> list[PageMessage]:
        if cmd is None:
            hello = PageHello(
                live=self.source.live,
                sim=self.source.sim,
                version=__version__,
                steer=client.right == "steer",
                driver=client.driver,
            )
            return [hello, *self.feed.snapshot(now), *self.source.extra()]
        if cmd.cmd == "reading":
            return [self.feed.reading(cmd.robot_id)]
        if cmd.cmd == "scans":  # the page draws other robots' scans now: their last ones (filtered on the loop)
            scans = self.feed.scans_now()
            return [scans] if scans is not None else []
        why = self.source.command(cmd)  # drives never come here: the loop relays them (_Pages._drive)
        return [PageError(error=why)] if why else []


MODEL_SUFFIXES = (".stl", ".gltf", ".glb")  # a robot type's model file (the page reads these; .bin: a glTF's buffers)


def model_files(models: Path | None) -> list[str]:
    """The model files in ``models`` the page may load (``<type>.stl``, ``.gltf`` or ``.glb``), sorted."""
    if models is None:
        return []
    return sorted(p.name for p in models.iterdir() if p.is_file() and p.suffix.lower() in MODEL_SUFFIXES)


def make_app(
    source: Source,
    feed: Feed,
    wake: threading.Event,
    *,
    max_pages: int = MAX_PAGES,
    access: Access | None = None,
    models: Path | None = None,
    name: str = "view",
) -> web.Application:
    """The web application: ``/`` the page, ``/static/`` its files, ``/ws`` its WebSocket,
    ``/models/`` the robot types' model files (``/models/index.json`` lists them: none without ``models``).

    The pump starts with the application and stops with it.

    Args:
        source: What the pages show.
        feed: The source's messages as page messages.
        wake: Set when the source has something.
        max_pages: Pages open at once; the next WebSocket is refused (HTTP 503).
        access: Who gets in (default: loopback names with their port, once the app serves).
        models: A directory of model files per robot type (``iwz view --models``), or None.
        name: The viewer's name: its pages drive as ``NAME#1``, ``NAME#2``...
    """
    pages = _Pages(source, feed, wake, max_pages, access or Access("127.0.0.1"), name)
    app = web.Application()
    app.on_startup.append(pages.start)
    app.on_cleanup.append(pages.cleanup)
    app.router.add_get("/", pages.index)
    app.router.add_get("/ws", pages.socket)
    app.router.add_static("/static/", STATIC)
    listed = model_files(models)

    async def model_index(_: web.Request) -> web.StreamResponse:
        return web.json_response(listed)

    app.router.add_get("/models/index.json", model_index)
    if models is not None:
        app.router.add_static("/models/", models)
    return app


class _Pages:
    """The open pages and the pump that feeds them (everything here runs on the server's loop,
    but what the pump hands over through ``call_soon_threadsafe``)."""

    def __init__(
        self, source: Source, feed: Feed, wake: threading.Event, max_pages: int, access: Access, name: str
    ) -> None:
        self.access = access
        self.name = name
        self.opened = 0  # pages ever opened: each gets the next driver name
        self.source = source
        self.feed = feed
        self.wake = wake
        self.max_pages = max_pages
        self.clients: set[Client] = set()
        self.pump: Pump | None = None

    def _ask(self, client: Client, cmd: PageCommand | None) -> None:
        assert self.pump is not None
        self.pump.ask(client, cmd)

    def _drive(self, client: Client, cmd: PageCommand) -> None:
        """Relays a page's drive command at once, on this loop (queued for the pump it waited for
        the pump's pass, tens of ms on a loaded machine); a refusal is told to the page."""
        assert cmd.drive is not None  # checked at the edge
        try:
            why = self.source.drive(cmd.robot_id, client.driver, cmd.drive)
            refused = PageError(error=f"cannot drive chair {cmd.robot_id}: {why}", drive_robot=cmd.robot_id)
            answer = [refused] if why else []
        except Exception as e:  # one page's command must not end its socket
            logger.exception("a page's drive %r failed", cmd)
            answer = [PageError(error=f"command failed: {type(e).__name__}: {str(e)[:200]}")]
        if answer and not client.closed and len(client.waiting) <= 4 * MAX_BACKLOG:
            client.waiting.extend(_ENCODER.encode(m).decode() for m in answer)
            client.ready.set()

    def on_loop(self, target: Client | None, data: list[Outgoing], snapshot: bool) -> None:
        """Queues what the pump encoded for one page, or for every page that has its snapshot
        (of the laser scans, only those each page draws)."""
        for c in [target] if target is not None else list(self.clients):
            if c.closed or not (c.joined or snapshot):
                continue
            if len(c.waiting) > MAX_BACKLOG and not snapshot:  # too far behind: start it afresh
                c.waiting.clear()
                c.joined = False
                self._ask(c, None)
                continue
            c.joined = True
            for d in data:
                text = d if isinstance(d, str) else d.for_page(c.scans)
                if text is not None:
                    c.waiting.append(text)
            c.ready.set()

    def _right(self, request: web.Request) -> tuple[str, web.Response | None]:
        """The request's right, or its refusal (HTTP 403 and why, logged)."""
        if not self.access.port and request.transport is not None:  # served on port 0: learn the one taken
            sock = request.transport.get_extra_info("sockname")
            self.access.port = int(sock[1]) if sock else 0
        right, why = self.access.right(
            request.headers.get("Host"), request.headers.get("Origin"), request.query.get("key")
        )
        if right:
            return right, None
        logger.warning("refused %s from %s: %s", request.path, request.remote, why)
        return "", web.Response(status=403, text=f"iwz view: {why}\n")

    async def index(self, request: web.Request) -> web.StreamResponse:
        """The page, to those let in."""
        _, refused = self._right(request)
        if refused is not None:
            return refused
        return web.FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-cache"})

    async def start(self, app: web.Application) -> None:
        """Starts the pump."""
        loop = asyncio.get_running_loop()

        def deliver(c: Client | None, d: list[Outgoing], s: bool) -> None:
            loop.call_soon_threadsafe(self.on_loop, c, d, s)

        self.pump = Pump(self.source, self.feed, self.wake, deliver)
        self.pump.start()

    async def cleanup(self, app: web.Application) -> None:
        """Stops the pump and closes every page's socket."""
        if self.pump is not None:
            self.pump.stop.set()
            self.wake.set()
            self.pump.join(5)
        for c in list(self.clients):
            await c.ws.close()

    async def socket(self, request: web.Request) -> web.StreamResponse:
        """One page's WebSocket: its snapshot, then what happens; its commands to the pump. Past
        ``max_pages`` pages open, refused with HTTP 503 and why; a request not let in, with 403."""
        right, refused = self._right(request)
        if refused is not None:
            return refused
        if len(self.clients) >= self.max_pages:
            why = (
                f"the viewer serves at most {self.max_pages} pages at once and all are open: close one, "
                "or start it with a larger --max-pages"
            )
            logger.warning("refused a page from %s: %s", request.remote, why)
            return web.Response(status=503, text=f"iwz view: {why}\n", headers={"Retry-After": "10"})
        ws = web.WebSocketResponse(max_msg_size=MAX_COMMAND_BYTES, heartbeat=30.0)
        self.opened += 1
        client = Client(ws, right=right, driver=driver_name(self.name, self.opened))
        self.clients.add(client)  # counted before the handshake's await: two pages cannot both take the last place
        try:
            await ws.prepare(request)
        except BaseException:
            self.clients.discard(client)
            raise
        sender = asyncio.create_task(_send(client))
        self._ask(client, None)
        try:
            async for msg in ws:
                if msg.type == WSMsgType.BINARY:
                    _refuse(client, "a command is a JSON text message, not binary (docs/viewer.md)")
                    continue
                if msg.type != WSMsgType.TEXT:
                    continue
                try:
                    cmd = _COMMAND.decode(msg.data)
                except msgspec.DecodeError as e:  # ValidationError is one
                    cmd = None
                    why = str(e)
                rate = client.drive_rate if cmd is not None and cmd.cmd == "drive" else client.rate
                if not rate.take(time.monotonic()):
                    if told := rate.tell(time.monotonic()):
                        _refuse(client, told)
                    continue
                if cmd is None or (why := check_command(cmd, client.right)):
                    _refuse(client, why)
                    continue
                if cmd.cmd == "drive":
                    client.driving = None if cmd.drive is not None and cmd.drive.release else cmd.robot_id
                    self._drive(client, cmd)
                    continue
                if cmd.cmd == "scans":  # from now on: what follows is filtered before it is queued
                    client.scans = ScansWanted.of(cmd)
                self._ask(client, cmd)
        finally:
            if client.driving is not None:  # the page is gone: its chair is released at once
                release = PageDriveInput(release=True)
                self._drive(client, PageCommand(cmd="drive", robot_id=client.driving, drive=release))
            client.closed = True
            self.clients.discard(client)
            client.ready.set()
            await sender
        return ws


def _refuse(client: Client, why: str) -> None:
    """Tells a page its command was refused, and why (nothing more once its queue is long: a page
    that floods and does not read costs a bounded amount)."""
    if len(client.waiting) > 4 * MAX_BACKLOG:
        return
    client.waiting.append(_ENCODER.encode(PageError(error=f"command refused: {why}")).decode())
    client.ready.set()


async def _send(client: Client) -> None:
    """Sends a page what waits for it, in order, until it closes."""
    while not client.closed:
        await client.ready.wait()
        client.ready.clear()
        while client.waiting and not client.closed:
            try:
                await client.ws.send_str(client.waiting.popleft())
            except (ConnectionError, RuntimeError):  # the page went away
                client.closed = True
