"""The legacy bridge's clients and their sockets: bounded, and closed when the client is gone.

A live Qt viewer sends ``<View/>``, then ``<LabReq/>``, ``<GridReq/>`` (0.5 s or 3 s after its
reply) and perhaps ``<Start/>``, and nothing more while it watches (the captures): silence alone
cannot say it is gone. What does: every client socket is connected to its client, so when nothing
listens there any more the kernel says so (ECONNREFUSED, from the ICMP the client's machine sends)
and the socket is closed; a viewer that has not said a word :data:`VIEWER_HANDSHAKE_S` after its
reply (a real viewer asks for the lab within 3 s) is let go; at most :data:`MAX_VIEWERS` are
served (when all are taken, one silent past :data:`VIEWER_QUIET_S` gives its place to a new one,
so a burst of ``<View/>`` keeps real viewers out for seconds at most); a second ``<View/>`` from a
served viewer is answered from its own socket; a robot the world no longer holds for
:data:`ROBOT_GONE_S` is let go. A legacy robot outlives its client (a silent one keeps its last
command, as in the legacy simulator, and a client may say nothing while it waits for Start), so
silence alone lets no robot go either; but at most :data:`MAX_ROBOTS` are served, each with its
own socket, and when all are taken the robot whose client has been silent longest, past
:data:`ROBOT_QUIET_S` (or that nothing listens for any more), gives its place and its socket to a
new one: a flood of registrations that never speak costs a bounded number of descriptors and
keeps no real client out.
"""

from __future__ import annotations

import contextlib
import logging
import selectors
import time
from collections.abc import Collection

from .transport import DatagramTransport, RobotLink, Viewer

__all__ = [
    "MAX_ROBOTS",
    "MAX_VIEWERS",
    "ROBOT_GONE_S",
    "ROBOT_QUIET_S",
    "VIEWER_HANDSHAKE_S",
    "VIEWER_QUIET_S",
    "Client",
    "ClientTable",
]

MAX_VIEWERS = 32  # viewers and panels served at once; more are refused with the reason
VIEWER_HANDSHAKE_S = 10.0  # a viewer silent this long after its reply is let go (a real one: 3 s)
VIEWER_QUIET_S = 5.0  # ... and one silent this long gives its place to a new viewer when all are taken
ROBOT_GONE_S = 3.0  # a robot missing from the world's states this long is gone
MAX_ROBOTS = 256  # legacy robots served at once, a socket each (a process has 1,024 descriptors by default)
ROBOT_QUIET_S = 10.0  # ... and one whose client is silent this long gives its place when all are taken

Peer = tuple[str, int]
Client = Viewer | RobotLink

logger = logging.getLogger(__name__)


class ClientTable:
    """The clients by address and robot id, and the selector over their sockets.

    Args:
        reception: The registration socket (watched too, with no client).
        max_viewers: Viewers and panels served at once.
        max_robots: Legacy robots served at once.
    """

    def __init__(
        self, reception: DatagramTransport, max_viewers: int = MAX_VIEWERS, max_robots: int = MAX_ROBOTS
    ) -> None:
        self.max_viewers = max_viewers
        self.max_robots = max_robots
        self.sel = selectors.DefaultSelector()
        self.sel.register(reception, selectors.EVENT_READ, (reception, None))
        self.by_peer: dict[Peer, Client] = {}
        self.by_robot: dict[int, RobotLink] = {}
        self._muted: dict[DatagramTransport, tuple[float, Client | None]] = {}  # not read until then
        self._unsent = (0.0, 0)  # when a failed send was last logged, and the failures since

    def get(self, peer: Peer) -> Client | None:
        """The client at ``peer``, if any."""
        return self.by_peer.get(peer)

    def add(self, c: Client) -> None:
        """Serves a new client from its own socket, connected to it (a client already at its
        address is let go first)."""
        old = self.by_peer.get(c.addr)
        if old is not None:
            self.drop(old)
        try:
            c.transport.connect(c.addr)
        except OSError:
            c.transport.close()  # an address no socket can talk to: no socket left behind
            raise
        self.by_peer[c.addr] = c
        if isinstance(c, RobotLink):
            self.by_robot[c.robot.robot_id] = c
        self.sel.register(c.transport, selectors.EVENT_READ, (c.transport, c))

    def mute(self, transport: DatagramTransport, client: Client | None, until: float) -> None:
        """Reads nothing from a socket until ``until`` (its budget is spent: what comes meanwhile
        waits in its buffer, or is dropped by the kernel when that is full, and costs nothing)."""
        with contextlib.suppress(KeyError, ValueError):
            self.sel.unregister(transport)
            self._muted[transport] = (until, client)

    def unmute(self, now: float) -> None:
        """Reads again the sockets whose time has come (those of clients let go meanwhile: no)."""
        for t, (until, c) in list(self._muted.items()):
            if now >= until:
                del self._muted[t]
                if c is None or self.by_peer.get(c.addr) is c:
                    self.sel.register(t, selectors.EVENT_READ, (t, c))

    def drop(self, c: Client) -> None:
        """Lets a client go: its socket is closed."""
        self._muted.pop(c.transport, None)
        if self.by_peer.get(c.addr) is c:
            del self.by_peer[c.addr]
        if isinstance(c, RobotLink) and self.by_robot.get(c.robot.robot_id) is c:
            del self.by_robot[c.robot.robot_id]
        with contextlib.suppress(KeyError, ValueError):
            self.sel.unregister(c.transport)
        c.transport.close()

    def send(self, c: Client, data: bytes) -> None:
        """Sends to a client. A client nobody listens for any more: a viewer is let go; a robot
        stays in the world (as in the legacy simulator, whose robots outlive their clients) and
        is told once. Other failures (a full buffer) are logged once a second, with their count."""
        if self.by_peer.get(c.addr) is not c:
            return  # let go a moment ago
        try:
            c.transport.sendto(data, c.addr)
        except ConnectionRefusedError:
            self.unreachable(c)
        except OSError as e:
            last, n = self._unsent
            now = time.monotonic()
            if now - last < 1.0:
                self._unsent = (last, n + 1)
                return
            self._unsent = (now, 0)
            more = f" ({n} more failed sends since the last line)" if n else ""
            logger.warning("cannot send to %s:%d: %s%s", c.addr[0], c.addr[1], e, more)

    def unreachable(self, c: Client) -> None:
        """Nothing listens at a client's address any more (see :meth:`send`)."""
        if isinstance(c, Viewer):
            self.drop(c)
            logger.info("legacy %s at %s:%d let go: nothing listens there any more", c.kind, *c.addr)
        elif not c.unreachable:
            c.unreachable = True
            logger.warning("legacy robot %d at %s:%d: nothing listens there any more", c.robot.robot_id, *c.addr)

    def expire(self, now: float) -> None:
        """Lets go the viewers silent since their reply for VIEWER_HANDSHAKE_S."""
        for v in self.silent_viewers(now):
            self.drop(v)
            logger.info("legacy viewer at %s:%d let go: not a word since its reply", *v.addr)

    def viewers(self, kind: str | None = None) -> list[Viewer]:
        """The viewers and panels served (of ``kind`` only, if given)."""
        return [c for c in self.by_peer.values() if isinstance(c, Viewer) and (kind is None or c.kind == kind)]

    def full(self, now: float) -> bool:
        """Whether as many viewers as may be are served, once the oldest viewer silent since its
        reply for VIEWER_QUIET_S (if any) has been let go to make room."""
        if len(self.viewers()) < self.max_viewers:
            return False
        quiet = self.silent_viewers(now, VIEWER_QUIET_S)
        if not quiet:
            return True
        self.drop(min(quiet, key=lambda v: v.since))
        return False

    def silent_viewers(self, now: float, after_s: float = VIEWER_HANDSHAKE_S) -> list[Viewer]:
        """Viewers (not panels: they never speak) silent since their reply, ``after_s`` ago."""
        return [v for v in self.viewers("viewer") if not v.heard and now - v.since > after_s]

    def robot_place(self, now: float) -> RobotLink | None | bool:
        """Whether a new robot may be served: True while fewer than ``max_robots`` are; else the
        robot to let go for it (its client silent longest, past ROBOT_QUIET_S, or unreachable);
        else False (every client spoke within ROBOT_QUIET_S: the new one is refused)."""
        if len(self.by_robot) < self.max_robots:
            return True
        quiet = [r for r in self.by_robot.values() if r.unreachable or now - r.heard > ROBOT_QUIET_S]
        if not quiet:
            return False
        return min(quiet, key=lambda r: (not r.unreachable, r.heard))

    def gone_robots(self, held: Collection[int], now: float) -> list[RobotLink]:
        """Notes which robots a state of the world holds; those it has not held for ROBOT_GONE_S."""
        gone = []
        for link in list(self.by_robot.values()):
            if link.robot.robot_id in held:
                link.seen = now
            elif now - link.seen > ROBOT_GONE_S:
                gone.append(link)
        return gone

    def ready(self, timeout_s: float) -> list[tuple[DatagramTransport, Client | None]]:
        """The sockets with datagrams (or an error) waiting, each with its client."""
        return [key.data for key, _ in self.sel.select(timeout=timeout_s)]

    def close(self) -> None:
        """Closes every client's socket."""
        for c in list(self.by_peer.values()):
            self.drop(c)
        self.sel.close()
