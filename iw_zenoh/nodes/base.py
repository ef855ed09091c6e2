"""What every node process shares: decoding with refusal events, publishing, liveliness,
signal handling and the logging set-up of ``main()``."""

from __future__ import annotations

import logging
import signal
import threading
from collections.abc import Callable
from typing import TypeVar

from iw_zenoh import keys
from iw_zenoh.bus import Bus, Delivery, Inbox
from iw_zenoh.errors import DecodeError
from iw_zenoh.messages import EventData, EventKind, Message, Outgoing, decode, encode, make_event

__all__ = ["NodeIO", "Outgoing", "install_stop_signals", "setup_logging"]

logger = logging.getLogger(__name__)

M = TypeVar("M", bound=Message)


class NodeIO:
    """A node's handle on the bus: inboxes that wake one loop, typed send, safe decode.

    Args:
        bus: The bus.
        sim: Simulation name.
        role: The process role (a liveliness role of :mod:`iw_zenoh.keys`).
        name: This instance's name.
    """

    def __init__(self, bus: Bus, sim: str, role: str, name: str) -> None:
        self.bus = bus
        self.sim = sim
        self.role = role
        self.name = name
        self.wake = threading.Event()
        self.stop = threading.Event()
        self.bad_messages = 0

    def inbox(self, key_expr: str, maxlen: int | None = None) -> Inbox:
        """Subscribes ``key_expr`` into a new inbox that wakes this node."""
        box = Inbox(maxlen=maxlen, wake=self.wake)
        self.bus.subscribe(key_expr, box)
        return box

    def alive(self) -> None:
        """Declares this process's liveliness token."""
        self.bus.token(keys.alive(self.sim, self.role, self.name))

    def send(self, key: str, msg: Message) -> None:
        """Publishes a message."""
        self.bus.publish(key, encode(msg))

    def send_all(self, out: list[Outgoing]) -> None:
        """Publishes several messages in order."""
        for key, msg in out:
            self.bus.publish(key, encode(msg))

    def event(
        self,
        kind: EventKind,
        reason: str,
        payload: EventData | None = None,
        *,
        tick: int = 0,
        sim_time_ns: int = 0,
        robot_id: int = -1,
        key: str = "",
    ) -> None:
        """Publishes an event of ``kind`` with its payload (see :func:`messages.make_event`), and logs it."""
        logger.info("event %s: %s", kind, reason)
        self.send(
            keys.event(self.sim, kind),
            make_event(
                kind,
                payload,
                reason=reason,
                tick=tick,
                sim_time_ns=sim_time_ns,
                robot_id=robot_id,
                key=key,
                source=f"{self.role}/{self.name}",
            ),
        )

    def decode(self, delivery: Delivery, kind: type[M]) -> M | None:
        """Decodes a delivery; a bad one is dropped with a ``bad-message`` event naming key and reason."""
        key, data, _ = delivery
        try:
            return decode(data, kind)
        except DecodeError as e:
            self.bad_message(key, e)
            return None

    def bad_message(self, key: str, error: Exception) -> None:
        """Reports a message dropped as malformed: counted, logged, and a ``bad-message`` event."""
        self.bad_messages += 1
        logger.warning("dropped a bad message on %s: %s", key, error)
        self.event(EventKind.BAD_MESSAGE, str(error), key=key)

    def wait(self, timeout_s: float) -> None:
        """Sleeps until something arrives, a stop is asked, or ``timeout_s`` passes."""
        if timeout_s > 0:
            self.wake.wait(timeout_s)
        self.wake.clear()


def install_stop_signals(stop: threading.Event, extra: Callable[[], None] | None = None) -> None:
    """SIGINT and SIGTERM set ``stop`` (the loop then closes the session and exits 0)."""

    def handler(signum: int, _frame: object) -> None:
        logger.info("signal %d: stopping", signum)
        stop.set()
        if extra is not None:
            extra()

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)


def setup_logging(verbosity: int, role: str) -> None:
    """Configures logging for a process (``-v`` info, ``-vv`` debug)."""
    level = logging.WARNING if verbosity <= 0 else logging.INFO if verbosity == 1 else logging.DEBUG
    logging.basicConfig(level=level, format=f"%(asctime)s {role} %(levelname)s %(name)s: %(message)s")
