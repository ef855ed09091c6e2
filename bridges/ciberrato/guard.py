"""What a flood may cost the legacy bridge: a datagram budget per source address, and refusals
told once per address and interval, with their counts, never once per datagram.

A flood from rotating source ports is one address: it gets one budget, one log line and one event
a second, whatever its ports. The tables here are bounded too (spoofed addresses cost no memory
past :data:`MAX_HOSTS`, and past :data:`MAX_REPORTS` addresses in an interval the rest are told
together as one). No sockets, no clock: the node hands in what came and when.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

__all__ = [
    "CLIENT_PER_S",
    "EVENT_EVERY_S",
    "FLOOD_PER_S",
    "MAX_HOSTS",
    "MAX_REPORTS",
    "OTHERS",
    "RECEPTION_PER_S",
    "FloodGuard",
    "Gate",
    "Refusals",
    "Report",
]

FLOOD_PER_S = 1000  # datagrams a second one address (any port) may send to the registration port
RECEPTION_PER_S = 5000  # datagrams a second read from the registration port at all (the rest wait or
# are dropped by the kernel: a flood costs the bridge this much reading, whatever its rate)
CLIENT_PER_S = 400  # datagrams a second a client may send to its own socket
EVENT_EVERY_S = 1.0  # at most one refusal report per address in this long
MAX_HOSTS = 4096  # addresses remembered at once (more: the quiet ones are forgotten)
MAX_REPORTS = 16  # addresses told one by one per interval; the others together, as OTHERS
OTHERS = "*"  # the address of the report that sums up the addresses past MAX_REPORTS


class FloodGuard:
    """Counts each source's datagrams per second: an address (any port) on the registration
    port, a client on its own socket.

    Args:
        per_s: Datagrams a source may send in a second before the rest are dropped unread.
    """

    def __init__(self, per_s: int) -> None:
        self.per_s = per_s
        self._rate: dict[object, tuple[float, int]] = {}
        self._pruned = 0.0

    def over(self, source: object, now: float) -> bool:
        """Counts one datagram from ``source`` at ``now`` (seconds); whether it is over the limit."""
        if len(self._rate) > MAX_HOSTS and now - self._pruned >= 1.0:
            # forget sources quiet for a second (spoofing costs no memory), once a second at most
            # (a table full of fresh spoofed addresses must not be rebuilt for every datagram)
            self._pruned = now
            self._rate = {p: v for p, v in self._rate.items() if now - v[0] < 1.0}
        start, n = self._rate.get(source, (now, 0))
        if now - start >= 1.0:
            start, n = now, 0
        self._rate[source] = (start, n + 1)
        return n + 1 > self.per_s

    def resumes_at(self, source: object, now: float) -> float | None:
        """When ``source`` has a budget again, if it has spent this second's; else None."""
        start, n = self._rate.get(source, (now, 0))
        return start + 1.0 if n > self.per_s and now - start < 1.0 else None


@dataclass
class Report:
    """The refusals of one address since it was last told.

    Attributes:
        host: The address (OTHERS: every address past MAX_REPORTS in the interval).
        port: The source port of the sample.
        reason: A sample reason (the first refused since the last report).
        count: Datagrams refused, the dropped ones included.
        dropped: Of those, datagrams over the flood limit, dropped unread.
        ports: Distinct source ports seen (counted up to 1024).
    """

    host: str
    port: int
    reason: str
    count: int = 0
    dropped: int = 0
    ports: set[int] = field(default_factory=set)

    def line(self, interval_s: float) -> str:
        """The report as one log line (and the event's reason)."""
        who = "other addresses" if self.host == OTHERS else self.host
        if self.count == 1:
            return f"refused a datagram from {who}:{self.port}: {self.reason}"
        extra = f"; {self.dropped} over the flood limit, dropped unread" if self.dropped else ""
        n_ports = f"{len(self.ports)}{'+' if len(self.ports) >= 1024 else ''}"
        return (
            f"refused {self.count} datagrams from {who} ({n_ports} source ports) within {interval_s:g} s{extra}; "
            f"e.g. from port {self.port}: {self.reason}"
        )


class Refusals:
    """Refused datagrams, told at most once per address every ``every_s``: the first refusal of a
    quiet address at once, what follows it summed up when the interval is over (:meth:`due`).

    Args:
        every_s: Seconds between two reports of one address.
        max_reports: Addresses told one by one per interval (the rest together).
    """

    def __init__(self, every_s: float = EVENT_EVERY_S, max_reports: int = MAX_REPORTS) -> None:
        self.every_s = every_s
        self.max_reports = max_reports
        self._open: dict[str, Report] = {}  # refusals not told yet, by address
        self._told: dict[str, float] = {}  # when each address was last told
        self._window = (0.0, 0)  # the interval's start and the addresses told in it
        self._scanned = -1e18  # when the open reports were last looked at

    def refuse(self, peer: tuple[str, int], reason: str, now: float, *, dropped: bool = False) -> Report | None:
        """Counts one refused datagram; the report to tell now, if any.

        Args:
            peer: Its sender.
            reason: Why it is refused.
            now: Monotonic seconds.
            dropped: It was over the flood limit and dropped unread.
        """
        host = peer[0]
        if host not in self._open and host not in self._told and len(self._told) >= MAX_HOSTS:
            host = OTHERS  # the table is full: counted with the others
        rep = self._open.get(host)
        if rep is None:
            rep = self._open[host] = Report(host, peer[1], reason)
        rep.count += 1
        rep.dropped += dropped
        if len(rep.ports) < 1024:
            rep.ports.add(peer[1])
        if now - self._told.get(host, -1e18) >= self.every_s:
            return self._tell(host, now)
        return None

    def due(self, now: float) -> list[Report]:
        """The reports whose interval is over (called every pass of the loop; they are looked
        for ten times an interval, so a pass costs nothing however many addresses are open)."""
        if now - self._scanned < self.every_s / 10:
            return []
        self._scanned = now
        out = [self._tell(h, now) for h in list(self._open) if now - self._told.get(h, -1e18) >= self.every_s]
        if len(self._told) > MAX_HOSTS:
            self._told = {h: t for h, t in self._told.items() if now - t < self.every_s or h in self._open}
        return [r for r in out if r is not None]

    def _tell(self, host: str, now: float) -> Report | None:
        """The address's report, counted against the interval's MAX_REPORTS (past it: OTHERS)."""
        start, n = self._window
        if now - start >= self.every_s:
            start, n = now, 0
        if n >= self.max_reports and host != OTHERS:
            rep = self._open.pop(host)  # told with the others, when they are due
            others = self._open.setdefault(OTHERS, Report(OTHERS, rep.port, f"{host}: {rep.reason}"))
            others.count += rep.count
            others.dropped += rep.dropped
            others.ports |= set(list(rep.ports)[: max(0, 1024 - len(others.ports))])
            self._told[host] = now
            return None
        self._window = (start, n + 1)
        self._told[host] = now
        return self._open.pop(host)


class Gate:
    """The bridge's door: the flood limits, and refusals told through ``tell`` (one report per
    address and interval).

    Args:
        tell: Tells a report (the node logs one line and publishes one event).
        per_host: Datagrams a second an address may send to the registration port.
        per_client: Datagrams a second a client may send to its own socket.
        every_s: Seconds between two reports of one address.
    """

    def __init__(
        self,
        tell: Callable[[Report], None],
        *,
        per_host: int = FLOOD_PER_S,
        per_client: int = CLIENT_PER_S,
        every_s: float = EVENT_EVERY_S,
        reception_per_s: int = RECEPTION_PER_S,
    ) -> None:
        self.tell = tell
        self.every_s = every_s
        self._reception = FloodGuard(reception_per_s)
        self._hosts = FloodGuard(per_host)
        self._clients = FloodGuard(per_client)
        self._refusals = Refusals(every_s)

    def let_in(self, peer: tuple[str, int], client: tuple[str, int] | None, now: float) -> bool:
        """Whether a datagram from ``peer`` is read: within its address's budget on the
        registration port (``client`` None), or its client's on the client's socket. One that
        is not is counted as refused, dropped unread."""
        if client is None:
            if self._reception.over(None, now):
                why = f"more than {self._reception.per_s} datagrams a second to the registration port"
            elif not self._hosts.over(peer[0], now):
                return True
            else:
                why = f"more than {self._hosts.per_s} datagrams a second from the address"
        else:
            if not self._clients.over(client, now):
                return True
            why = f"more than {self._clients.per_s} datagrams a second to a client's socket"
        self.refuse(peer, why, now, dropped=True)
        return False

    def resumes_at(self, client: tuple[str, int] | None, now: float) -> float | None:
        """When a socket that has spent this second's budget (the registration port's, ``client``
        None, or a client's) is to be read again; None while it has not."""
        if client is None:
            return self._reception.resumes_at(None, now)
        return self._clients.resumes_at(client, now)

    def refuse(self, peer: tuple[str, int], reason: str, now: float, *, dropped: bool = False) -> None:
        """Counts a refused datagram; tells it if its address has not been told within the interval."""
        rep = self._refusals.refuse(peer, reason, now, dropped=dropped)
        if rep is not None:
            self.tell(rep)

    def due(self, now: float) -> None:
        """Tells the reports whose interval is over (every pass of the loop)."""
        for rep in self._refusals.due(now):
            self.tell(rep)
