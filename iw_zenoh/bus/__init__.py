"""The message bus every node talks through: a small protocol, and its Zenoh implementation.

Nodes never call Zenoh directly. Subscriptions deliver ``(key, payload, receive_ns)`` into an
:class:`Inbox` (a thread-safe queue the node drains in its own loop: Zenoh's callbacks only
append). Queries to a queryable land in a :class:`QueryInbox` the node answers from its loop.
Everything is published with congestion control BLOCK: nothing that must arrive is dropped.
"""

from __future__ import annotations

import collections
import json
import logging
import threading
import time
from collections.abc import Callable, Sequence
from typing import Protocol

import zenoh

from iw_zenoh.bus.net import NetConfig, zenoh_config
from iw_zenoh.bus.publishers import Publishers
from iw_zenoh.errors import IwError

__all__ = [
    "INBOX_KEPT",
    "NEWEST_KEPT",
    "Asked",
    "Bus",
    "Delivery",
    "Handle",
    "Inbox",
    "PendingQuery",
    "QueryInbox",
    "Queue",
    "Wake",
    "ZenohBus",
]

logger = logging.getLogger(__name__)

Delivery = tuple[str, bytes, int]  # key, payload, receive time (ns, wall clock)

# an inbox nobody drains for a while (a stalled loop, a flood) must not grow without bound:
INBOX_KEPT = 100_000  # deliveries one holds at most: minutes of a busy key; beyond, the oldest are lost and logged
NEWEST_KEPT = 16  # ... of a key whose next message supersedes the last (a state, a tick): the newest few
LOST_LOG_S = 1.0  # losses are logged at most this often per inbox


class Wake(Protocol):
    """What an inbox sets on a delivery: a :class:`threading.Event` (a node's loop waits on it), or
    an object that acts on the delivering thread (:class:`iw_zenoh.agent.hosting.InlineAnswers`)."""

    def is_set(self) -> bool:
        """Whether it is set already (then a delivery does not set it again)."""

    def set(self) -> None:
        """Called on a delivery, on the bus's thread."""


class Handle(Protocol):
    """Something declared on the bus that can be undeclared."""

    def undeclare(self) -> None:
        """Stops it."""


class Inbox:
    """A thread-safe FIFO of deliveries, filled by the bus, drained by one node loop.

    Receiving is kept cheap, since every message a node hears passes here: ``put`` takes no lock
    (``deque.append`` and ``popleft`` are atomic in CPython), wakes a waiter of :meth:`get` or
    :meth:`wait` only when there is one, and sets ``wake`` only when it is not set already (a
    burst of deliveries wakes the loop once: a loop clears ``wake`` before it drains, so nothing
    put after the clear goes unseen).

    Bounded: beyond ``maxlen`` deliveries waiting, the oldest is lost; :attr:`lost` counts the
    losses (seen when the inbox is read), which are logged unless ``newest_only`` says they are
    expected.

    Args:
        maxlen: Keep only the newest ``maxlen`` deliveries.
        wake: Set on every delivery: an event one node loop waits on for all its inboxes, or a
            :class:`Wake` that acts on the delivering thread.
        newest_only: Only the newest deliveries matter to the reader (older ones are superseded):
            losing older ones is not worth a warning.
    """

    def __init__(self, maxlen: int = INBOX_KEPT, wake: Wake | None = None, *, newest_only: bool = False) -> None:
        self._q: collections.deque[Delivery] = collections.deque(maxlen=maxlen)
        self._cv = threading.Condition()
        self._waiters = 0  # threads in get() or wait(), counted under _cv
        self._wake = wake
        self.received = 0
        self.lost = 0
        self._taken = 0
        self._newest_only = newest_only
        self._logged = -LOST_LOG_S

    def put(self, item: Delivery) -> None:
        """Adds a delivery (called from the bus's thread)."""
        self._q.append(item)
        self.received += 1
        # a waiter counts itself under _cv before it looks at the queue: if it is not counted
        # yet, it will see this item when it looks
        if self._waiters:
            with self._cv:
                self._cv.notify_all()
        wake = self._wake
        if wake is not None and not wake.is_set():
            wake.set()

    def get(self, timeout_s: float | None = None) -> Delivery | None:
        """The oldest delivery, waiting up to ``timeout_s`` (``None``: forever); ``None`` on timeout."""
        with self._cv:
            self._waiters += 1
            try:
                if not self._q and not self._cv.wait_for(lambda: bool(self._q), timeout=timeout_s):
                    return None
                self._count_lost()
                self._taken += 1
                return self._q.popleft()
            finally:
                self._waiters -= 1

    def drain(self) -> list[Delivery]:
        """Every delivery waiting now, oldest first."""
        if not self._q and self.received == self._taken + self.lost:
            return []  # nothing waiting, no loss uncounted: a loop drains its quiet inboxes every pass
        self._count_lost()
        out: list[Delivery] = []
        pop = self._q.popleft
        try:
            for _ in range(len(self._q)):
                out.append(pop())
        except IndexError:  # a bounded inbox dropped its oldest for a newer one meanwhile
            pass
        self._taken += len(out)
        return out

    def _count_lost(self) -> None:
        """Counts the deliveries lost to the bound: received, but neither taken nor waiting (by the one
        reader: ``put`` appends before it counts, so a loss is never over-counted)."""
        lost = self.received - self._taken - len(self._q)
        if lost <= self.lost:
            return
        self.lost = lost
        now = time.monotonic()
        if not self._newest_only and now - self._logged >= LOST_LOG_S:
            self._logged = now
            logger.warning(
                "an inbox overflowed: %d deliveries lost so far, the oldest of %d waiting (its reader fell behind)",
                lost,
                self._q.maxlen,
            )

    def wait(self, timeout_s: float) -> bool:
        """Waits until something is waiting; False on timeout."""
        with self._cv:
            self._waiters += 1
            try:
                return self._cv.wait_for(lambda: bool(self._q), timeout=timeout_s)
            finally:
                self._waiters -= 1

    def __len__(self) -> int:
        return len(self._q)


class Queue(Protocol):
    """A lossless queue filled by the bus without Python in the way (for the recorder): when it
    is full the network waits, nothing is dropped."""

    def drain(self, limit: int = 100_000) -> list[Delivery]:
        """Up to ``limit`` deliveries waiting now, oldest first (receive time = when drained)."""

    def undeclare(self) -> None:
        """Stops it."""


class _ZenohQueue:
    def __init__(self, session: zenoh.Session, key_expr: str, capacity: int) -> None:
        self._sub = session.declare_subscriber(key_expr, zenoh.handlers.FifoChannel(capacity))

    def drain(self, limit: int = 100_000) -> list[Delivery]:
        out: list[Delivery] = []
        now = time.time_ns()
        while len(out) < limit:
            s = self._sub.try_recv()
            if s is None:
                break
            out.append((str(s.key_expr), s.payload.to_bytes(), now))
        return out

    def undeclare(self) -> None:
        self._sub.undeclare()  # type: ignore[no-untyped-call]


class PendingQuery:
    """A query waiting for its answer."""

    def __init__(self, key: str, payload: bytes, reply: Callable[[bytes], None]) -> None:
        self.key = key
        self.payload = payload
        self._reply = reply

    def reply(self, data: bytes) -> None:
        """Answers the query (once)."""
        self._reply(data)


class Asked:
    """A query sent without waiting: its answers come in while the asker goes on with its loop."""

    def __init__(self) -> None:
        self.replies: list[bytes] = []  # appended by the network's thread (list.append is atomic)
        self.done = threading.Event()  # every answer is in, or the query timed out

    def answered(self) -> bool:
        """Whether an answer is in, or none will come."""
        return bool(self.replies) or self.done.is_set()


class QueryInbox(Protocol):
    """Queries to one queryable, answered from the node's loop."""

    def poll(self) -> list[PendingQuery]:
        """Every query waiting now."""

    def undeclare(self) -> None:
        """Stops serving."""


class Bus(Protocol):
    """What a node needs from the network."""

    def publish(self, key: str, data: bytes) -> None:
        """Publishes one payload on a key (never dropped)."""

    def subscribe(self, key_expr: str, inbox: Inbox, *, ordered: bool = False) -> Handle:
        """Delivers every payload matching ``key_expr`` into ``inbox``; ``ordered``: in the order
        they came over the network with every other ordered subscription of this bus (else each
        subscription is delivered on its own and two keys may overtake each other)."""

    def serve(self, key: str) -> QueryInbox:
        """Declares a queryable on ``key``."""

    def query(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> list[bytes]:
        """Asks every queryable matching ``key``; their answers (possibly none)."""

    def ask(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> Asked:
        """Sends a query and returns at once; the answers arrive in the returned object."""

    def token(self, key: str) -> Handle:
        """Declares a liveliness token that lives as long as the process."""

    def watch_alive(self, key_expr: str, on_change: Callable[[str, bool], None]) -> Handle:
        """Calls ``on_change(key, alive)`` for every token matching (current ones first)."""

    def close(self) -> None:
        """Closes everything."""


class _ZenohQueryInbox:
    def __init__(self, session: zenoh.Session, key: str) -> None:
        self._key = key
        self._q = session.declare_queryable(key, zenoh.handlers.FifoChannel(256))

    def poll(self) -> list[PendingQuery]:
        out: list[PendingQuery] = []
        while True:
            q = self._q.try_recv()
            if q is None:
                return out
            payload = q.payload.to_bytes() if q.payload is not None else b""

            def reply(data: bytes, q: zenoh.Query = q) -> None:
                try:
                    q.reply(q.key_expr if "*" in self._key else self._key, data)  # a pattern answers on the key asked
                finally:
                    q.drop()  # type: ignore[no-untyped-call]

            out.append(PendingQuery(str(q.key_expr), payload, reply))

    def undeclare(self) -> None:
        self._q.undeclare()  # type: ignore[no-untyped-call]


def _endpoints(conf: zenoh.Config, key: str, mode: str) -> list[str]:
    """The endpoints a configuration names at ``key`` (for ``mode`` when given per mode)."""
    value = json.loads(conf.get_json(key))
    if isinstance(value, dict):
        value = value.get(mode, [])
    return [str(v) for v in value or []]


class _Kept:
    """A declared subscription or token that leaves its bus's table when undeclared (an agent
    host drops a removed robot's subscription), so the table holds what is declared now, not
    everything ever declared; the bus undeclares what is left when it closes."""

    def __init__(self, handle: Handle, table: dict[int, Handle]) -> None:
        self._handle = handle
        self._table = table
        table[id(self)] = self

    def undeclare(self) -> None:
        self._table.pop(id(self), None)
        self._handle.undeclare()


def _tls_cause(net: NetConfig, endpoints: Sequence[str]) -> str:
    """A secured client's join refused: which certificate and why ("" when none is found, or not secured)."""
    if net.identity is None or net.mode != "client":
        return ""
    from iw_zenoh.secure.diagnose import join_refused  # only a secured process that failed to join needs it

    why = join_refused(net.identity, list(endpoints))
    return f"as the identity {net.identity}: {why}" if why else ""


class ZenohBus:
    """The bus over a real Zenoh session.

    Args:
        net: How to join (default: client of the local router).
    """

    def __init__(self, net: NetConfig | None = None) -> None:
        self.net = net or NetConfig()
        conf = zenoh_config(self.net)
        self.listening: list[str] = _endpoints(conf, "listen/endpoints", self.net.mode)
        try:
            self.session = zenoh.open(conf)
        except zenoh.ZError as e:
            named = self.net.connect or self.net.listen
            where = ", ".join(named or _endpoints(conf, "connect/endpoints", self.net.mode))
            cause = _tls_cause(self.net, named or _endpoints(conf, "connect/endpoints", self.net.mode))
            raise IwError(
                f"cannot join the bus ({self.net.mode} of {where}): {cause}"
                if cause
                else f"cannot join the bus ({self.net.mode} of {where}): {e}. "
                "Is `iwz router` running there (or use `iwz run`)? Is the port free, for a router?"
            ) from None
        # per-key publishers, those of keys gone quiet (robots that left) undeclared
        self._pubs: Publishers[zenoh.Publisher] = Publishers(self._declare_publisher)
        self._handles: dict[int, Handle] = {}  # what is declared now, in order

    def _declare_publisher(self, key: str) -> zenoh.Publisher:
        return self.session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)

    def publish(self, key: str, data: bytes) -> None:
        """Puts ``data`` on ``key`` through the key's own publisher (declared on first use,
        congestion control BLOCK: a slow subscriber holds the sender back, nothing is dropped)."""
        try:
            self._pubs.get(key).put(data)
        except zenoh.ZError:
            # swept by another thread between its look-up and this put (a key quiet for a whole
            # sweep, used again at that instant): declare it again, once
            self._pubs.get(key).put(data)

    def subscribe(self, key_expr: str, inbox: Inbox, *, ordered: bool = False) -> Handle:
        """Puts every sample on ``key_expr`` into ``inbox`` as ``(key, payload, receive time in
        ns)``; ``ordered`` delivers on Zenoh's network thread, in the network's order (dearer)."""

        def on_sample(sample: zenoh.Sample) -> None:
            inbox.put((str(sample.key_expr), sample.payload.to_bytes(), time.time_ns()))

        def on_sample_of_key(sample: zenoh.Sample) -> None:
            inbox.put((key_expr, sample.payload.to_bytes(), time.time_ns()))

        # a key without wildcards is every sample's own key: not asked of each sample (a robot's
        # sensors key delivers every tick)
        plain = on_sample if "*" in key_expr or "$" in key_expr else on_sample_of_key

        # a plain function runs in a Python thread of its own (zenoh-python's Callback
        # indirect=True), so two subscriptions may overtake each other; run on Zenoh's network
        # thread (indirect=False) deliveries keep the network's order, but it cost more CPU per
        # message (bus_floor: 0.125-0.139 against 0.109-0.111 ms) and, while the loop computed,
        # delivered 3-15x later: only where the order matters (the radio: a say before the verdict
        # it precedes)
        handler = zenoh.handlers.Callback(plain, indirect=False) if ordered else plain
        return _Kept(self.session.declare_subscriber(key_expr, handler), self._handles)

    def queue(self, key_expr: str, capacity: int = 200_000) -> Queue:
        """A lossless queue on ``key_expr``: samples wait in Zenoh's own channel (no Python
        callback, no GIL on the network path); when full, the sender is held back."""
        q = _ZenohQueue(self.session, key_expr, capacity)
        self._handles[id(q)] = q
        return q

    def serve(self, key: str) -> QueryInbox:
        """A queryable on ``key``: its queries wait in the returned inbox to be answered."""
        q = _ZenohQueryInbox(self.session, key)
        self._handles[id(q)] = q
        return q

    def query(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> list[bytes]:
        """Asks ``key`` and waits up to ``timeout_s`` for every answer; the answers' payloads
        (errors left out, each logged with its payload).

        Every replier's answer is kept (no consolidation): Zenoh's default keeps one answer per
        key, the last to arrive, so a second queryable on the key (another world on the same
        simulation) silently replaced the first one's answer."""
        out: list[bytes] = []
        errors: list[str] = []
        t0 = time.monotonic()
        for reply in self.session.get(
            key, payload=payload, timeout=timeout_s, consolidation=zenoh.ConsolidationMode.NONE
        ):
            if reply.ok is not None:
                out.append(reply.ok.payload.to_bytes())
            elif reply.err is not None:
                errors.append(reply.err.payload.to_bytes().decode(errors="replace")[:200])
        if errors:  # a timeout is said at info level (a busy world), any other error as a warning
            level = logging.INFO if set(errors) == {"Timeout"} else logging.WARNING
            logger.log(level, "query %s: %d answers, error replies: %s", key, len(out), errors)
        logger.debug("query %s: %d answers in %.1f ms", key, len(out), (time.monotonic() - t0) * 1e3)
        return out

    def ask(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> Asked:
        """Asks ``key`` without waiting: the answers' payloads gather in the returned
        :class:`Asked`, whose ``done`` is set once the query ends (all answered, or timed out)."""
        asked = Asked()

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                asked.replies.append(reply.ok.payload.to_bytes())
            elif reply.err is not None:
                why = reply.err.payload.to_bytes().decode(errors="replace")[:200]
                logger.log(logging.INFO if why == "Timeout" else logging.WARNING, "query %s: error reply: %s", key, why)

        self.session.get(
            key,
            zenoh.handlers.Callback(on_reply, asked.done.set),
            payload=payload,
            timeout=timeout_s,
            consolidation=zenoh.ConsolidationMode.NONE,  # every replier's answer (see query)
        )
        return asked

    def token(self, key: str) -> Handle:
        """Declares a liveliness token on ``key`` (this process is alive there until undeclared)."""
        return _Kept(self.session.liveliness().declare_token(key), self._handles)

    def watch_alive(self, key_expr: str, on_change: Callable[[str, bool], None]) -> Handle:
        """Calls ``on_change(key, alive)`` for every liveliness token on ``key_expr`` that appears
        or goes, those alive already included (history)."""

        def on_sample(sample: zenoh.Sample) -> None:
            on_change(str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)

        return _Kept(self.session.liveliness().declare_subscriber(key_expr, on_sample, history=True), self._handles)

    def declared(self) -> int:
        """How many subscriptions, tokens, queues and queryables this bus holds declared now."""
        return len(self._handles)

    def close(self) -> None:
        """Undeclares everything this bus declared, newest first, then closes the session."""
        for h in reversed(list(self._handles.values())):
            try:
                h.undeclare()
            except Exception:  # already gone with a closing session
                logger.debug("undeclare failed", exc_info=True)
        self._handles.clear()
        self._pubs.clear()
        if not self.session.is_closed():
            try:
                self.session.close()  # type: ignore[no-untyped-call]
            except Exception as e:  # zenoh's close can time out (ZError, a starved runtime): stopping goes on
                logger.warning("the bus session did not close cleanly: %s", e)

    def __enter__(self) -> ZenohBus:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
