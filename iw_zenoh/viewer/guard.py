"""Who may use the viewer's page and what a page may ask (pure: no sockets, no clock of its own).

A request is let in by its origin or by a key. ``Origin`` (sent by every browser on a WebSocket)
must be the page's own (``http://`` + the request's ``Host``): a page of another site is refused;
``Origin: null`` (a sandboxed frame, a ``data:`` or ``file:`` page, on any site) gets in only with a key.
A viewer served on loopback (the default) lets in, without a key, the loopback names of its own
port (``127.0.0.1``, ``localhost``, ``[::1]``), with the right to steer; any other ``Host`` (DNS
rebinding: a foreign name resolved to 127.0.0.1) needs a key. A viewer served on any other
address lets in nobody without a key. Each start draws two keys: the *watch* key (read-only:
the page, a robot's reading, which scans to draw) and the *steer* key (also the world's controls
and a replay's play, pause, step, seek and rate, which every page sees).

Every command a page sends is then checked here at the edge: its right, its bounds (an obstacle's
name and coordinates) and its rate (:class:`Rate`), each refusal with a reason for that page only.
"""

from __future__ import annotations

import hmac
import ipaddress
import math
import secrets
from dataclasses import dataclass, field
from urllib.parse import urlsplit

from iw_zenoh.messages.page import PageCommand

__all__ = [
    "LOOPBACK_NAMES",
    "MAX_COORD_M",
    "MAX_NAME",
    "WATCH_COMMANDS",
    "Access",
    "Rate",
    "check_command",
    "is_loopback",
]

LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")  # what a browser on this machine calls it
WATCH_COMMANDS = frozenset({"reading", "scans"})  # what a read-only page may ask: they change nothing shared
MAX_NAME = 64  # characters of an obstacle's name
MAX_COORD_M = 100_000.0  # metres: far beyond any lab, well within what a float carries exactly
MAX_HEIGHT_M = 1_000.0


def is_loopback(host: str) -> bool:
    """Whether serving on ``host`` (an address or a name) serves this machine only."""
    h = host.strip("[]")
    if h == "localhost":
        return True
    try:
        return ipaddress.ip_address(h).is_loopback
    except ValueError:
        return False


@dataclass
class Access:
    """The rules of one start of ``iwz view``: where it serves, its port (known once it serves),
    and its two keys (drawn anew each start)."""

    host: str
    port: int = 0
    watch_key: str = field(default_factory=lambda: secrets.token_urlsafe(18))
    steer_key: str = field(default_factory=lambda: secrets.token_urlsafe(18))

    @property
    def local(self) -> bool:
        """Served on loopback only."""
        return is_loopback(self.host)

    def _own_host(self, host: str) -> bool:
        names = {f"{n}:{self.port}" for n in LOOPBACK_NAMES}
        if self.port == 80:
            names.update(LOOPBACK_NAMES)
        return host.lower() in names

    def right(self, host: str | None, origin: str | None, key: str | None) -> tuple[str, str]:
        """The right of a request (``"steer"``, ``"watch"``, or ``""`` with why it is refused).

        Args:
            host: Its ``Host`` header.
            origin: Its ``Origin`` header (``None``: not a browser's page, or the same origin;
                ``"null"``: an opaque origin, any site's sandboxed frame, needs the key).
            key: The ``key`` in its address.
        """
        host = host or ""
        if origin == "null" and not key:  # a sandboxed iframe, a data: or file: page: anyone's
            return "", (
                "Origin 'null' (a sandboxed frame, a data: or file: page) may be any site's page: it may not "
                "watch or steer this viewer without the key; open the address iwz view printed"
            )
        if origin is not None and origin != "null":
            o = urlsplit(origin)
            if o.scheme not in ("http", "https") or o.netloc.lower() != host.lower():
                return "", (
                    f"Origin {origin[:100]!r} is not this viewer's page (Host {host[:100]!r}): a page of another "
                    "site may not watch or steer it; open the address iwz view printed"
                )
        if key:
            if hmac.compare_digest(key.encode(), self.steer_key.encode()):
                return "steer", ""
            if hmac.compare_digest(key.encode(), self.watch_key.encode()):
                return "watch", ""
            return (
                "",
                "the key in the address is not this viewer's (new at each start): use the address iwz view printed",
            )
        if self.local and self._own_host(host):
            return "steer", ""
        if self.local:
            return "", (
                f"Host {host[:100]!r} is not this viewer's address ({', '.join(LOOPBACK_NAMES)} with port "
                f"{self.port}): a foreign name pointing here (DNS rebinding?) needs the key iwz view printed"
            )
        return "", "this viewer serves the network: only its addresses with a key get in (printed at its start)"

    def addresses(self, shown_host: str) -> tuple[str, str]:
        """The watch and steer addresses of the page, on ``shown_host``."""
        base = f"http://{shown_host}:{self.port}/?key="
        return base + self.watch_key, base + self.steer_key


def check_command(cmd: PageCommand, right: str) -> str:
    """Why a page with ``right`` may not send ``cmd`` ("" when it may): beyond a watch key, or out
    of bounds (the decoder already bounded its ids, steps, times and rate)."""
    if cmd.cmd == "drive":
        return _check_drive(cmd, right)
    if cmd.cmd not in WATCH_COMMANDS and right != "steer":
        return (
            f"{cmd.cmd!r} steers the run: this page may only watch (its key is the watch key; steer with the steer key)"
        )
    ob = cmd.obstacle
    if ob is None:
        return ""
    if not 0 < len(ob.name) <= MAX_NAME or not ob.name.isprintable():
        return f"an obstacle's name is 1 to {MAX_NAME} printable characters"
    for name, v in (("x0", ob.x0), ("y0", ob.y0), ("x1", ob.x1), ("y1", ob.y1)):
        if not (math.isfinite(v) and abs(v) <= MAX_COORD_M):
            return f"the obstacle's {name} is {v!r}: give a finite number of metres within ±{MAX_COORD_M:g}"
    if not (math.isfinite(ob.height) and 0 < ob.height <= MAX_HEIGHT_M):
        return f"the obstacle's height is {ob.height!r}: give metres in (0, {MAX_HEIGHT_M:g}]"
    return ""


def _check_drive(cmd: PageCommand, right: str) -> str:
    """Why a page may not send this ``drive`` ("" when it may): it drives a chair, so only with
    the steer right; its input present, its goal finite (the decoder bounded the rest)."""
    if right != "steer":
        return "driving a chair needs the steer right: this page may only watch (its key is the watch key)"
    d = cmd.drive
    if d is None:
        return "a drive command needs its input: {robot_id, drive: {seq, x, y, buttons, level, ...}}"
    if d.goto is not None and not all(math.isfinite(v) and abs(v) <= MAX_COORD_M for v in d.goto):
        return f"go there needs a finite point within ±{MAX_COORD_M:g} m, not {d.goto!r}"
    return ""


@dataclass
class Rate:
    """A page's commands per second: a bucket of ``burst`` refilled at ``per_s``; past it a command
    is refused, and only one refusal a second is told (with how many more were dropped)."""

    per_s: float = 20.0
    burst: float = 40.0
    _level: float = -1.0
    _at: float = 0.0
    _told_at: float = -math.inf
    dropped: int = 0

    def take(self, now_s: float) -> bool:
        """Whether a command at ``now_s`` (monotonic seconds) is within the rate."""
        if self._level < 0:
            self._level, self._at = self.burst, now_s
        self._level = min(self.burst, self._level + (now_s - self._at) * self.per_s)
        self._at = now_s
        if self._level >= 1:
            self._level -= 1
            return True
        self.dropped += 1
        return False

    def tell(self, now_s: float) -> str:
        """The refusal to send now ("" when one was told within the last second)."""
        if now_s - self._told_at < 1.0:
            return ""
        self._told_at = now_s
        n, self.dropped = self.dropped, 0
        return f"more than {self.per_s:g} commands a second from this page: {n} dropped; slow down"
