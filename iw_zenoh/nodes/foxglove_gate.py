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

A request head larger than :data:`HEAD_MAX` or slower than :data:`HEAD_TIMEOUT_S` is refused, and
at most :data:`CLIENTS_MAX` clients are served at once (more get ``503``): a flood costs a bounded
amount, and other clients are unaffected.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading

__all__ = ["CLIENTS_MAX", "SDK", "SUBPROTOCOLS", "WEBSOCKET", "FoxgloveGate", "refusal", "rewrite_head"]

logger = logging.getLogger(__name__)

SDK = "foxglove.sdk.v1"  # what foxglove-sdk's server speaks (Foxglove today)
WEBSOCKET = "foxglove.websocket.v1"  # the same protocol's former name (Lichtblick, @foxglove/ws-protocol)
SUBPROTOCOLS = (SDK, WEBSOCKET)
HEAD_MAX = 16 * 1024  # a handshake is a few hundred bytes
HEAD_TIMEOUT_S = 10.0  # a client that has not sent its handshake by then is dropped
CLIENTS_MAX = 64  # clients served at once
CHUNK = 64 * 1024


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


def rewrite_head(head: bytes) -> tuple[bytes, str | None, bytes]:
    """What to send the server for a client's request head, and how to answer the client.

    Args:
        head: The request head, up to and with its blank line.

    Returns:
        ``(head to forward, name to give back, refusal)``: the name is ``None`` when the server's
        answer passes as it is; a non-empty refusal means: send it and close (nothing forwarded).
    """
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

    Raises:
        OSError: The address cannot be bound (its reason).
    """

    def __init__(self, host: str, port: int, upstream: int) -> None:
        self._upstream = upstream
        self._clients = 0
        self._loop = asyncio.new_event_loop()
        self._server = self._loop.run_until_complete(asyncio.start_server(self._serve, host, port, limit=HEAD_MAX))
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
            forward, name, refused = rewrite_head(head)
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
