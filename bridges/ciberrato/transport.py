"""The datagram sockets the legacy bridge is given (a small protocol, and the real one on UDP),
and the legacy clients on them.

The node never opens a socket itself: it is handed a reception transport and a factory of the
per-client ones, so its logic runs in a test against fakes, and against real UDP in production.
"""

from __future__ import annotations

import contextlib
import errno
import os
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
    "PortTaken",
    "UdpTransport",
    "Viewer",
    "port_owner",
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

    def connect(self, peer: Peer, /) -> None:
        """Talks to ``peer`` alone from now on: datagrams from any other address never reach it,
        and once nothing listens at ``peer`` any more, receiving or sending raises
        ConnectionRefusedError (what says that a client is gone)."""

    def close(self) -> None:
        """Closes it."""


TransportFactory = Callable[[], DatagramTransport]


class PortTaken(OSError):
    """The registration port is bound by another socket; ``owner`` says whose, when it can be
    found."""

    def __init__(self, bind: str, port: int, owner: str) -> None:
        super().__init__(errno.EADDRINUSE, f"UDP {bind}:{port} is taken" + (f" by {owner}" if owner else ""))
        self.owner = owner


class UdpTransport:
    """A UDP socket, non-blocking, bound to ``(bind, port)`` (port 0: any free one).

    No SO_REUSEADDR nor SO_REUSEPORT: on Linux either lets a second process bind a UDP port that is
    in use and take its datagrams (a second bridge on 6000 stole the first one's registrations).

    Args:
        bind: Address.
        port: Port.

    Raises:
        PortTaken: When another socket has the port.
        OSError: When the address cannot be bound for another reason.
    """

    def __init__(self, bind: str, port: int = 0) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind((bind, port))
            self.sock.setblocking(False)
        except OSError as e:
            self.sock.close()
            if e.errno == errno.EADDRINUSE:
                raise PortTaken(bind, port, port_owner(port)) from None
            raise
        self.port = int(self.sock.getsockname()[1])

    def connect(self, peer: Peer, /) -> None:
        """Talks to ``peer`` alone (see :meth:`DatagramTransport.connect`)."""
        self.sock.connect(peer)

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


def _socket_inodes(port: int) -> set[str]:
    """The inodes of the UDP sockets bound to ``port`` (from /proc/net/udp and udp6)."""
    inodes = set()
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        with contextlib.suppress(OSError), open(table) as f:
            next(f, None)
            for row in f:
                cols = row.split()
                if len(cols) > 9 and int(cols[1].rsplit(":", 1)[1], 16) == port:
                    inodes.add(cols[9])
    return inodes


def _holds(pid: str, links: set[str]) -> bool:
    """Whether process ``pid`` has one of the sockets ``links`` open (False if it cannot be seen)."""
    try:
        fds = os.listdir(f"/proc/{pid}/fd")
    except OSError:
        return False
    for fd in fds:
        with contextlib.suppress(OSError):
            if os.readlink(f"/proc/{pid}/fd/{fd}") in links:
                return True
    return False


def port_owner(port: int) -> str:
    """Who has UDP ``port``: "pid N (command line)" for each process of this machine whose socket
    it is and that may be looked at, else "another process"; "" when no socket has it."""
    inodes = _socket_inodes(port)
    if not inodes:
        return ""
    links = {f"socket:[{i}]" for i in inodes}
    owners = []
    for pid in (p for p in os.listdir("/proc") if p.isdigit()):
        if _holds(pid, links):
            with contextlib.suppress(OSError), open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\x00", b" ").decode(errors="replace").strip()
                owners.append(f"pid {pid} ({cmd[:120]})")
    return ", ".join(owners) or "another process (its pid cannot be seen from here)"


def udp_factory(bind: str) -> TransportFactory:
    """Per-client UDP sockets on ``bind``, each on a free port (as the legacy server's)."""
    return lambda: UdpTransport(bind)


class QueueBus(Bus, Protocol):
    """A bus that also gives lossless queues polled from the node's loop (:class:`ZenohBus`)."""

    def queue(self, key_expr: str, capacity: int = 200_000) -> Queue:
        """A queue of every payload matching ``key_expr``."""


@dataclass
class Viewer:
    """A legacy viewer (or panel) and its own socket.

    Attributes:
        since: When it registered (monotonic seconds).
        heard: Whether it has sent anything to its own socket since (a Qt viewer asks for the lab
            0.5 s or 3 s after its reply).
    """

    kind: str  # viewer, panel
    addr: Peer
    transport: DatagramTransport
    since: float = 0.0
    heard: bool = False


@dataclass
class RobotLink:
    """A legacy robot's address, its own socket and its state.

    Attributes:
        seen: When the world's state last held the robot (monotonic seconds; at first, when it
            was accepted).
        unreachable: Nothing listens at its address any more (told once).
        heard: When its client last sent a datagram to its own socket (monotonic seconds; at
            first, when it was accepted).
    """

    addr: Peer
    transport: DatagramTransport
    robot: LegacyRobot
    seen: float = 0.0
    unreachable: bool = False
    heard: float = 0.0
