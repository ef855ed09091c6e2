"""The datagram sockets the legacy bridge is given (a small protocol, and the real one on UDP),
and the legacy clients on them.

The node never opens a socket itself: it is handed a reception transport and a factory of the
per-client ones, so its logic runs in a test against fakes, and against real UDP in production.
"""

from __future__ import annotations

import socket
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from iw_zenoh.bus import Bus, Queue

from .robot import LegacyRobot

__all__ = [
    "DatagramTransport",
    "QueueBus",
    "RobotLink",
    "TransportFactory",
    "UdpTransport",
    "Viewer",
    "udp_factory",
]

Peer = tuple[str, int]


class DatagramTransport(Protocol):
    """A non-blocking datagram socket."""

    def sendto(self, data: bytes, peer: Peer, /) -> int:
        """Sends one datagram to ``peer``; the bytes sent."""

    def recvfrom(self, size: int, /) -> tuple[bytes, Peer]:
        """One datagram and its sender.

        Raises:
            BlockingIOError: When none is waiting.
        """

    def fileno(self) -> int:
        """The descriptor a selector watches."""

    def close(self) -> None:
        """Closes it."""


TransportFactory = Callable[[], DatagramTransport]


class UdpTransport:
    """A UDP socket, non-blocking, bound to ``(bind, port)`` (port 0: any free one).

    Args:
        bind: Address.
        port: Port.
        reuse: Set SO_REUSEADDR (the registration port, as the legacy server does).

    Raises:
        OSError: When the address cannot be bound.
    """

    def __init__(self, bind: str, port: int = 0, *, reuse: bool = False) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            if reuse:
                self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self.sock.bind((bind, port))
            self.sock.setblocking(False)
        except OSError:
            self.sock.close()
            raise
        self.port = int(self.sock.getsockname()[1])

    def sendto(self, data: bytes, peer: Peer, /) -> int:
        """Sends one datagram."""
        return self.sock.sendto(data, peer)

    def recvfrom(self, size: int, /) -> tuple[bytes, Peer]:
        """One datagram and its sender (BlockingIOError when none waits)."""
        data, peer = self.sock.recvfrom(size)
        return data, (str(peer[0]), int(peer[1]))

    def fileno(self) -> int:
        """The socket's descriptor."""
        return self.sock.fileno()

    def close(self) -> None:
        """Closes the socket."""
        self.sock.close()


def udp_factory(bind: str) -> TransportFactory:
    """Per-client UDP sockets on ``bind``, each on a free port (as the legacy server's)."""
    return lambda: UdpTransport(bind)


class QueueBus(Bus, Protocol):
    """A bus that also gives lossless queues polled from the node's loop (:class:`ZenohBus`)."""

    def queue(self, key_expr: str, capacity: int = 200_000) -> Queue:
        """A queue of every payload matching ``key_expr``."""


@dataclass
class Viewer:
    """A legacy viewer (or panel) and its own socket."""

    kind: str  # viewer, panel
    addr: Peer
    transport: DatagramTransport


@dataclass
class RobotLink:
    """A legacy robot's address, its own socket and its state."""

    addr: Peer
    transport: DatagramTransport
    robot: LegacyRobot
