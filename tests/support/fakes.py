"""Fakes for the bridge's unit tests: a bus that records what is published and answers queries
from the test, and datagram transports with no socket (a pipe tells the selector one waits)."""

from __future__ import annotations

import collections
import os
from collections.abc import Callable

from iw_zenoh.bridges.ciberrato.node import Bridge

from iw_zenoh.bus import Asked, Delivery, Handle, Inbox, QueryInbox

Peer = tuple[str, int]


class _Handle:
    def undeclare(self) -> None:
        pass


class FakeQueue:
    """A bus queue the test fills."""

    def __init__(self) -> None:
        self.items: list[Delivery] = []

    def put(self, key: str, data: bytes) -> None:
        self.items.append((key, data, 0))

    def drain(self, limit: int = 100_000) -> list[Delivery]:
        out, self.items = self.items[:limit], self.items[limit:]
        return out

    def undeclare(self) -> None:
        pass


class FakeBus:
    """Records publications; each ask is answered by ``answer`` (or left in flight when None)."""

    def __init__(self) -> None:
        self.published: list[tuple[str, bytes]] = []
        self.queues: dict[str, FakeQueue] = {}
        self.asks: list[tuple[str, bytes, Asked]] = []
        self.answer: Callable[[str, bytes], list[bytes] | None] = lambda key, payload: []
        self.info: list[bytes] = []

    def publish(self, key: str, data: bytes) -> None:
        self.published.append((key, data))

    def subscribe(self, key_expr: str, inbox: Inbox, *, ordered: bool = False) -> Handle:
        return _Handle()

    def queue(self, key_expr: str, capacity: int = 200_000) -> FakeQueue:
        return self.queues.setdefault(key_expr, FakeQueue())

    def serve(self, key: str) -> QueryInbox:
        raise NotImplementedError

    def query(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> list[bytes]:
        return list(self.info)

    def ask(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> Asked:
        asked = Asked()
        replies = self.answer(key, payload)
        if replies is not None:
            asked.replies.extend(replies)
            asked.done.set()
        self.asks.append((key, payload, asked))
        return asked

    def token(self, key: str) -> Handle:
        return _Handle()

    def watch_alive(self, key_expr: str, on_change: Callable[[str, bool], None]) -> Handle:
        return _Handle()

    def close(self) -> None:
        pass


class FakeTransport:
    """A datagram transport with no socket: ``deliver`` queues a datagram, ``sent`` records."""

    def __init__(self) -> None:
        self._r, self._w = os.pipe()
        os.set_blocking(self._r, False)
        self.inbox: collections.deque[tuple[bytes, Peer]] = collections.deque()
        self.sent: list[tuple[bytes, Peer]] = []
        self.closed = False
        self.peer: Peer | None = None  # connected to
        self.refused = False

    def connect(self, peer: Peer, /) -> None:
        self.peer = peer

    def deliver(self, data: bytes, peer: Peer) -> None:
        self.inbox.append((data, peer))
        os.write(self._w, b"x")

    def gone(self) -> None:
        """Nothing listens at the connected peer any more: the kernel says so on the next read."""
        self.refused = True
        os.write(self._w, b"x")

    def sendto(self, data: bytes, peer: Peer, /) -> int:
        if self.closed:
            raise OSError(9, "Bad file descriptor")
        self.sent.append((data, peer))
        return len(data)

    def recvfrom(self, size: int, /) -> tuple[bytes, Peer]:
        if self.refused:
            self.refused = False
            os.read(self._r, 1)
            raise ConnectionRefusedError(111, "Connection refused")
        if not self.inbox:
            raise BlockingIOError
        os.read(self._r, 1)
        data, peer = self.inbox.popleft()
        return data[:size], peer

    def fileno(self) -> int:
        return self._r

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            os.close(self._r)
            os.close(self._w)


class Transports:
    """The factory of client transports; every one it made, in order."""

    def __init__(self) -> None:
        self.made: list[FakeTransport] = []

    def __call__(self) -> FakeTransport:
        t = FakeTransport()
        self.made.append(t)
        return t


Rig = tuple[Bridge, FakeBus, FakeTransport, Transports]  # what the rig fixture (conftest.py) yields
