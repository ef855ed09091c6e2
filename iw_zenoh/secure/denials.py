"""What the router's access control refused, read from Zenoh's own log: who, what, on which key.

Zenoh logs its access-control decisions at trace level only, each naming the session id (and, on
first sight, the identity: ``CertCommonName(alice)``) and the key. :class:`DenialLog` reads those
lines and keeps the refusals of messages that were really sent: the permissions Zenoh works out
in advance for a newly declared key (every kind of message, sent or not) are passed over, and a
refusal repeated on the same key is reported once, then counted (a flood stays one line a second).

Zenoh writes a trace line for every message it lets through as well (``Using cached result: ...
is authorized``): :meth:`DenialLog.read` takes a whole block of lines at once and looks at the
few that can matter with regular expressions, so the allowed traffic costs no Python per line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

__all__ = ["Denial", "DenialLog"]

_ANSI = re.compile(rb"\x1b\[[0-9;]*m")
_CACHING = re.compile(rb"ThreadId\((\d+)\).*caching permissions for `([^`]*)`")
_DIRECT = re.compile(
    rb"ThreadId\((\d+)\).* ([0-9a-f]+) on (\S+) is unauthorized to (.+?) \((ingress|egress)\) on (\S+)"
)
_CACHED = re.compile(rb"Using cached result: ([0-9a-f]+) is unauthorized to (.+?) \((ingress|egress)\) on (\S+)")
_CN = re.compile(r"CertCommonName\(([^)]*)\)")
_STRANGER = re.compile(rb"([0-9a-f]+) did not match any configured ACL subject")
_ACCESS_CONTROL = re.compile(rb"access_control|unauthorized")
_NOTABLE = (b"unauthorized", b"caching permissions", b"ACL subject")  # words of the lines that matter
REPEAT_NS = 1_000_000_000  # the same refusal again: counted, reported at most once a second
KEPT = 4096  # sessions named, and refusals remembered for their repeats, at most (sessions come and go)


@dataclass(frozen=True)
class Denial:
    """One refusal: who was refused what, on which key, and how often since the last report."""

    identity: str
    message: str
    flow: str
    key: str
    times: int = 1

    def __str__(self) -> str:
        """As the router logs it."""
        more = f" ({self.times} times)" if self.times > 1 else ""
        side = "from" if self.flow == "ingress" else "to"
        return f"access denied: {self.message} {side} {self.identity!r} on {self.key}{more}"


@dataclass
class DenialLog:
    """Turns Zenoh's access-control log lines into :class:`Denial` reports."""

    _names: dict[str, str] = field(default_factory=dict)  # session id -> identity
    _caching: dict[str, str] = field(default_factory=dict)  # thread -> key whose permissions it works out
    _last: dict[tuple[str, str, str, str], tuple[int, int]] = field(default_factory=dict)  # -> (reported at, count)
    _pruned: int = -(2**62)  # when _last was last pruned (ns)

    def read(self, block: bytes, now_ns: int) -> tuple[bytes, list[Denial]]:
        """Whole lines of Zenoh's log at once: the lines that are not about access control (to
        pass on unchanged) and the refusals to report, in order.

        Args:
            block: Complete lines, each ending in a newline (ANSI colours allowed).
            now_ns: Now, in ns of any monotonic clock (for the once-a-second rule).
        """
        found: list[Denial] = []
        for start in sorted({s for word in _NOTABLE for s in _line_starts(block, word)}):
            denial = self.feed(block[start : block.find(b"\n", start)], now_ns)
            if denial is not None:
                found.append(denial)
        if block.count(b"access_control") == block.count(b"\n"):
            return b"", found  # Zenoh's access-control lines only (each names its target once)
        lines = block.split(b"\n")  # complete lines: the last piece is empty
        return b"".join(line + b"\n" for line in lines[:-1] if not _ACCESS_CONTROL.search(line)), found

    def feed(self, line: bytes, now_ns: int) -> Denial | None:
        """One line of Zenoh's log; a refusal to report, or None.

        Args:
            line: The line (ANSI colours allowed).
            now_ns: Now, in ns of any monotonic clock (for the once-a-second rule).
        """
        if b"unauthorized" not in line and b"caching permissions" not in line and b"ACL subject" not in line:
            return None
        line = _ANSI.sub(b"", line)
        m = _STRANGER.search(line)
        if m:  # a certificate of the authority the policy does not name: everything refused, unlogged
            return Denial(f"session {m[1].decode()} (no identity of the policy)", "every message", "ingress", "any key")
        m = _CACHING.search(line)
        if m:
            self._caching[m[1].decode()] = m[2].decode()
            return None
        m = _DIRECT.search(line)
        if m:
            thread, zid, subject, message, flow, key = (g.decode(errors="replace") for g in m.groups())
            cn = _CN.search(subject)
            self._names.pop(zid, None)  # the newest last: the oldest named are forgotten past KEPT
            self._names[zid] = cn[1] if cn else subject
            if len(self._names) > KEPT:
                del self._names[next(iter(self._names))]
            if self._caching.get(thread) == key:
                return None  # worked out in advance for a declared key, not a message sent
            return self._report(self._names[zid], message, flow, key, now_ns)
        m = _CACHED.search(line)
        if m:
            zid, message, flow, key = (g.decode(errors="replace") for g in m.groups())
            return self._report(self._names.get(zid, f"session {zid}"), message, flow, key, now_ns)
        return None

    def _report(self, identity: str, message: str, flow: str, key: str, now_ns: int) -> Denial | None:
        what = (identity, message, flow, key)
        at, count = self._last.get(what, (now_ns - REPEAT_NS, 0))
        if now_ns - at < REPEAT_NS:
            self._last[what] = (at, count + 1)
            return None
        self._last[what] = (now_ns, 0)
        if len(self._last) > KEPT and now_ns - self._pruned >= REPEAT_NS:  # at most once a second:
            self._pruned = now_ns  # the refusals not repeated for a second are forgotten
            self._last = {w: v for w, v in self._last.items() if now_ns - v[0] < REPEAT_NS}
        return Denial(identity, message, flow, key, times=count + 1)


def _line_starts(block: bytes, word: bytes) -> list[int]:
    """Where each line of ``block`` holding ``word`` starts (bytes.find: no Python per other line)."""
    out = []
    at = block.find(word)
    while at >= 0:
        start = block.rfind(b"\n", 0, at) + 1
        out.append(start)
        end = block.find(b"\n", at)
        at = block.find(word, end) if end >= 0 else -1
    return out
