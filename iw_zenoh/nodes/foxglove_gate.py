"""The door of Foxglove live: one port that serves both names of the Foxglove WebSocket protocol.

foxglove-sdk's server (every version to date, its handshake in ``rust/foxglove/src/websocket/
handshake.rs``) accepts only the subprotocol ``foxglove.sdk.v1``; Lichtblick and the
``@foxglove/ws-protocol`` client library offer ``foxglove.websocket.v1``, the same protocol under its
former name (Foxglove's stated position; Lichtblick added the new name beside the old one). So the
sdk's server listens on a loopback port of its own, and this gate listens where users connect:

* a handshake offering ``foxglove.sdk.v1`` passes as it is;
* one offering only ``foxglove.websocket.v1`` is passed on as ``foxglove.sdk.v1``, and the server's
  answer is given back under the name the client asked for (``Sec-WebSocket-Accept`` depends on
  the key alone, so nothing else changes); after the handshake the bytes flow through untouched;
* one offering neither (or no WebSocket at all) is refused with ``400`` and a body that says which
  subprotocols are served and which were offered.

A handshake that carries an ``Origin`` (every browser's page sends one) is served only from the
origins of Foxglove's and Lichtblick's own apps (:data:`APP_ORIGINS`), from pages served on this
machine's loopback names (``http://127.0.0.1:*``, ``http://localhost:*``, ``http://[::1]:*``: a
Lichtblick or Foxglove served locally) and from the origins the user adds (``--allow-origin``);
any other is refused with ``403`` and a reason naming the flag: otherwise any web page the user
visits could open ``ws://127.0.0.1:8765`` and read the live run. A handshake without ``Origin``
(a desktop app, a script) passes: it is not a web page acting for another site.

A request head larger than :data:`HEAD_MAX` or slower than :data:`HEAD_TIMEOUT_S` is refused, and
at most :data:`CLIENTS_MAX` clients are served at once (more get ``503``): a flood costs a bounded
amount, and other clients are unaffected.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
from collections.abc import Iterable
from urllib.parse import urlsplit

from iw_zenoh.viewer.guard import is_loopback

__all__ = [
    "APP_ORIGINS",
    "CLIENTS_MAX",
    "SDK",
    "SUBPROTOCOLS",
    "WEBSOCKET",
    "FoxgloveGate",
    "origin_refusal",
    "refusal",
    "rewrite_head",
]

logger = logging.getLogger(__name__)

SDK = "foxglove.sdk.v1"  # what foxglove-sdk's server speaks (Foxglove today)
WEBSOCKET = "foxglove.websocket.v1"  # the same protocol's former name (Lichtblick, @foxglove/ws-protocol)
SUBPROTOCOLS = (SDK, WEBSOCKET)
HEAD_MAX = 16 * 1024  # a handshake is a few hundred bytes
HEAD_TIMEOUT_S = 10.0  # a client that has not sent its handshake by then is dropped
CLIENTS_MAX = 64  # clients served at once
CHUNK = 64 * 1024
# the origins the apps' own pages send: Foxglove's web app; the desktop apps of Foxglove and
# Lichtblick (Electron, their page a file: URL) send none or "file://"
APP_ORIGINS = ("https://app.foxglove.dev", "file://")
ALLOW_FLAG = "--allow-origin (iwz foxglove) or --foxglove-allow-origin (iwz view)"


def _norm(origin: str) -> str:
    return origin.strip().lower().rstrip("/") if origin.strip().lower() != "file://" else "file://"


def _origin(head: bytes) -> str | None:
    """The request head's ``Origin`` header (``None``: it has none)."""
    for line in head.split(b"\r\n")[1:]:
        name, _, value = line.partition(b":")
        if name.strip().lower() == b"origin":
            return value.decode("latin-1").strip()
    return None


def origin_refusal(head: bytes, allowed: Iterable[str] = ()) -> bytes:
    """The ``403`` for a request head whose ``Origin`` may not read the run (``b""``: it may).

    Args:
        head: The request head.
        allowed: Origins the user added (``https://studio.example``), beside :data:`APP_ORIGINS`
            and the loopback pages.
    """
    origin = _origin(head)
    if origin is None:
        return b""
    norm = _norm(origin)
    if norm in {_norm(o) for o in (*APP_ORIGINS, *allowed)}:
        return b""
    try:
        o = urlsplit(norm)
        if o.scheme in ("http", "https") and o.hostname and is_loopback(o.hostname):
            return b""
    except ValueError:
        pass
    why = (
        f"Origin {origin[:100]!r} may not read this run: this Foxglove server (iw-zenoh) serves pages of "
        f"{', '.join(APP_ORIGINS)} and of this machine's loopback names, so that another site's page cannot "
        f"read it; to let that page in, add its origin with {ALLOW_FLAG}"
    )
    return refusal("403 Forbidden", why)


def _offered(head: bytes) -> list[str]:
    """The subprotocols a request head offers (every ``Sec-WebSocket-Protocol`` header, in order)."""
    out: list[str] = []
    for line in head.split(b"\r\n")[1:]:
        name, _, value = line.partition(b":")
        if name.strip().lower() == b"sec-websocket-protocol":
            out += [v.strip() for v in value.decode("latin-1").split(",") if v.strip()]
    return out


def refusal(status: str, why: str) -> bytes:
    """An HTTP response that refuses a client, saying why (``status``: ``400 Bad Request``...)."""
    body = why.encode()
    return (
        f"HTTP/1.1 {status}\r\nContent-Type: text/plain; charset=utf-8\r\nContent-Length: {len(body)}\r\n"
        "Connection: close\r\n\r\n"
    ).encode() + body


def rewrite_head(head: bytes, allowed: Iterable[str] = ()) -> tuple[bytes, str | None, bytes]:
    """What to send the server for a client's request head, and how to answer the client.

    Args:
        head: The request head, up to and with its blank line.
        allowed: Origins let in beside the apps' and loopback's (see :func:`origin_refusal`).

    Returns:
        ``(head to forward, name to give back, refusal)``: the name is ``None`` when the server's
        answer passes as it is; a non-empty refusal means: send it and close (nothing forwarded).
    """
    if refused := origin_refusal(head, allowed):
        return b"", None, refused
    offered = _offered(head)
    if SDK in offered:
        return head, None, b""
    if WEBSOCKET in offered:
        lines = [
            line for line in head.split(b"\r\n") if line.partition(b":")[0].strip().lower() != b"sec-websocket-protocol"
        ]
        lines.insert(1, f"Sec-WebSocket-Protocol: {SDK}".encode())
        return b"\r\n".join(lines), WEBSOCKET, b""
    why = (
        f"this Foxglove WebSocket server (iw-zenoh) serves the subprotocols {SDK} and {WEBSOCKET}; "
        f"the request offered {', '.join(offered) if offered else 'none'} (Sec-WebSocket-Protocol)"
    )
    return b"", None, refusal("400 Bad Request", why)


class FoxgloveGate:
    """Listens on ``host:port`` and passes each client to the server at ``127.0.0.1:upstream``.

    Args:
        host: Where clients connect.
        port: Its port (0: any free one, then read ``.port``).
        upstream: The loopback port of foxglove-sdk's server.
        allow_origins: Web pages' origins let in beside the apps' and loopback's.

    Raises:
        OSError: The address cannot be bound (its reason; nothing is left open).
    """

    def __init__(self, host: str, port: int, upstream: int, allow_origins: Iterable[str] = ()) -> None:
        self._upstream = upstream
        self._allowed = tuple(allow_origins)
        self._clients = 0
        self._loop = asyncio.new_event_loop()
        try:
            self._server = self._loop.run_until_complete(asyncio.start_server(self._serve, host, port, limit=HEAD_MAX))
        except BaseException:
            self._loop.close()
            raise
        self.port: int = self._server.sockets[0].getsockname()[1]
        self._thread = threading.Thread(target=self._loop.run_forever, name="foxglove-gate", daemon=True)
        self._thread.start()

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._clients += 1
        try:
            if self._clients > CLIENTS_MAX:
                writer.write(refusal("503 Service Unavailable", f"{CLIENTS_MAX} clients already served: try later"))
                return
            try:
                head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), HEAD_TIMEOUT_S)
            except (asyncio.LimitOverrunError, ValueError):
                writer.write(refusal("431 Request Header Fields Too Large", f"a request head over {HEAD_MAX} bytes"))
                return
            except (asyncio.IncompleteReadError, TimeoutError, ConnectionError):
                return
            forward, name, refused = rewrite_head(head, self._allowed)
            if refused:
                writer.write(refused)
                return
            await self._relay(reader, writer, forward, name)
        finally:
            self._clients -= 1
            with contextlib.suppress(ConnectionError):
                await writer.drain()
            writer.close()

    async def _relay(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter, head: bytes, name: str | None
    ) -> None:
        try:
            up_r, up_w = await asyncio.open_connection("127.0.0.1", self._upstream, limit=HEAD_MAX)
        except OSError as e:
            writer.write(refusal("502 Bad Gateway", f"the Foxglove server is not there: {e}"))
            return
        try:
            up_w.write(head)
            answer = await asyncio.wait_for(up_r.readuntil(b"\r\n\r\n"), HEAD_TIMEOUT_S)
            if name is not None:
                answer = answer.replace(f": {SDK}\r\n".encode(), f": {name}\r\n".encode())
            writer.write(answer)
            await asyncio.gather(_pipe(reader, up_w), _pipe(up_r, writer))
        except (asyncio.IncompleteReadError, asyncio.LimitOverrunError, TimeoutError, ConnectionError):
            logger.debug("a Foxglove client's relay ended", exc_info=True)
        finally:
            up_w.close()

    def close(self) -> None:
        """Stops listening and ends every relay (idempotent)."""
        if not self._loop.is_running():
            return

        async def _stop() -> None:
            self._server.close()
            for task in asyncio.all_tasks():
                if task is not asyncio.current_task():
                    task.cancel()

        asyncio.run_coroutine_threadsafe(_stop(), self._loop).result(5)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(5)
        if not self._loop.is_running():
            self._loop.close()


async def _pipe(src: asyncio.StreamReader, dst: asyncio.StreamWriter) -> None:
    """Copies ``src`` to ``dst`` until either side closes, then closes ``dst``."""
    try:
        while data := await src.read(CHUNK):
            dst.write(data)
            await dst.drain()
    except ConnectionError:
        pass
    finally:
        dst.close()
