"""How a role process starts and stops: its arguments, logging, bus, signals.

Every role's ``main()`` hands :func:`start_role` only what is its own (its description and
examples, its flags, a warm-up, what it prepares before joining, what it runs); the rest is
here, once: ``--sim``, ``-v``, ``--name`` and the network flags, the logging set-up, opening the
bus (a failure prints ``iwz ROLE: reason`` and exits 2), SIGINT, SIGTERM and SIGHUP, closing the bus,
and, in a process ``iwz run`` started, stopping as SIGTERM would once that ``iwz run`` is gone.
A role's typed options (a ``msgspec.Struct`` its flags fill) are :mod:`iw_zenoh.process.options`'.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar, overload

from iw_zenoh import keys
from iw_zenoh.bus import INBOX_KEPT, NEWEST_KEPT, Bus, Delivery, Inbox, Wake, ZenohBus
from iw_zenoh.bus.refusals import RefusalLimiter, counted
from iw_zenoh.errors import DecodeError, IwError
from iw_zenoh.messages import BadMessageData, EventData, EventKind, Message, Outgoing, decode, encode, make_event
from iw_zenoh.process.cliargs import add_common_arguments, net_from_args
from iw_zenoh.process.options import (
    options_from_args,  # re-exported: nodes/world.py and nodes/sensors.py import it from here
)

__all__ = [
    "SUPERVISOR_ENV",
    "NodeIO",
    "Outgoing",
    "Process",
    "install_stop_signals",
    "options_from_args",
    "setup_logging",
    "start_role",
    "watch_supervisor",
]

logger = logging.getLogger(__name__)

SUPERVISOR_ENV = "IWZ_SUPERVISOR"  # the pid of the ``iwz run`` that started this process
SUPERVISOR_POLL_S = 0.5  # how often a started process looks whether its ``iwz run`` is still there
# then stopped, how long it has before it kills itself, as iwz run would have killed it: longer
# than iwz run gives a recorder to finish its file (nodes.child.RECORDER_STOP_S, 45 s)
SUPERVISOR_GRACE_S = 60.0
REFUSALS_FLUSH_S = 1.0  # how often every role reports the refusals it counted (refusals.PERIOD_NS)
PID_MAX = 4_194_304  # the largest pid Linux gives (its pid_max at most)

M = TypeVar("M", bound=Message)
T = TypeVar("T")


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
        self.refusals = RefusalLimiter()  # bad-message reports: one per key and reason a second

    def inbox(
        self, key_expr: str, maxlen: int | None = None, *, ordered: bool = False, wake: Wake | None = None
    ) -> Inbox:
        """Subscribes ``key_expr`` into a new inbox that wakes this node.

        Args:
            key_expr: The key expression.
            maxlen: Deliveries kept waiting at most (None: by what the key carries, the newest
                :data:`~iw_zenoh.bus.NEWEST_KEPT` of a key whose messages supersede each other,
                else :data:`~iw_zenoh.bus.INBOX_KEPT`, beyond which losses are logged).
            ordered: Delivered in the network's order with the node's other ordered inboxes
                (see :meth:`iw_zenoh.bus.Bus.subscribe`).
            wake: What a delivery sets (default: this node's :attr:`wake`).
        """
        newest = keys.superseded(key_expr)
        kept = maxlen if maxlen is not None else NEWEST_KEPT if newest else INBOX_KEPT
        box = Inbox(maxlen=kept, wake=wake or self.wake, newest_only=newest)
        self.bus.subscribe(key_expr, box, ordered=ordered)
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
        """Reports a message dropped as malformed or out of the protocol: counted, and refused
        (:meth:`refuse`, its reason the error's kind)."""
        self.bad_messages += 1
        self.refuse(type(error).__name__, str(error), key=key)  # a decode error, a protocol error...

    def refuse(self, reason: str, text: str, *, key: str, robot_id: int = -1, tick: int = 0) -> None:
        """A message on ``key`` refused for ``reason`` (a category; ``text`` says it): a warning and a
        ``bad-message`` event at most once per key and reason a second, with how many it stands for."""
        n = self.refusals.admit(key, reason, time.monotonic_ns(), text)
        if n:
            self._report_refusal(key, text, n, robot_id, tick)

    def flush_refusals(self, *, last: bool = False) -> None:
        """Reports the refusals counted and not reported once their second is over (``last``: all
        of them, the process stopping); :meth:`report_refusals`' thread calls it once a second."""
        now = time.monotonic_ns() + (self.refusals.period_ns if last else 0)
        for key, _, n, text in self.refusals.due(now):
            self._report_refusal(key, text, n, -1, 0)

    def report_refusals(self, every_s: float = REFUSALS_FLUSH_S) -> Callable[[], None]:
        """Starts a thread that reports every role's counted refusals (:meth:`flush_refusals`) each
        ``every_s``, so a flood that stopped has its count said whatever the role's loop does;
        returns what stops it, after a last report of what is still counted."""
        done = threading.Event()

        def loop() -> None:
            while not done.wait(every_s):
                self._flush_safely(last=False)

        thread = threading.Thread(target=loop, name="refusals", daemon=True)
        thread.start()

        def stop() -> None:
            done.set()
            thread.join()
            self._flush_safely(last=True)

        return stop

    def _flush_safely(self, *, last: bool) -> None:
        try:
            self.flush_refusals(last=last)
        except Exception as e:  # the bus closing under it: said, the role is not killed for it
            logger.warning("could not report counted refusals: %s", e)

    def _report_refusal(self, key: str, text: str, n: int, robot_id: int, tick: int) -> None:
        logger.warning("refused a message on %s: %s", key, counted(text, n))
        self.event(
            EventKind.BAD_MESSAGE, counted(text, n), BadMessageData(count=n), key=key, robot_id=robot_id, tick=tick
        )

    def wait(self, timeout_s: float) -> None:
        """Sleeps until something arrives, a stop is asked, or ``timeout_s`` passes."""
        if timeout_s > 0:
            self.wake.wait(timeout_s)
        self.wake.clear()


def install_stop_signals(stop: threading.Event, extra: Callable[[], None] | None = None) -> None:
    """SIGINT, SIGTERM and SIGHUP set ``stop`` (the loop then closes the session and exits 0): a
    role started by hand in a terminal that is then closed stops as Ctrl-C would have stopped it
    (a recorder finishes its file) instead of dying where it stands."""

    def handler(signum: int, _frame: object) -> None:
        logger.info("signal %d: stopping", signum)
        stop.set()
        if extra is not None:
            extra()

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)
    signal.signal(signal.SIGHUP, handler)


def watch_supervisor(poll_s: float = SUPERVISOR_POLL_S, grace_s: float = SUPERVISOR_GRACE_S) -> threading.Thread | None:
    """In a process ``iwz run`` started (:data:`SUPERVISOR_ENV` names its pid), sends this
    process SIGTERM once that ``iwz run`` is gone, so it stops as it would have been stopped: a
    launcher killed (SIGKILL, out of memory, a crash) leaves no router holding its port, no world
    or agents driving chairs, and a recording finished, not cut off. Every role then stops at
    once (the ordered stop, agents first, was the launcher's). One still running ``grace_s``
    later (its main thread blocked where the signal's handler never runs, a stop that hangs) is
    killed, as ``iwz run`` kills what does not stop. The variable is taken out of this process's
    environment, so processes it starts do not watch a pid not their parent.

    Args:
        poll_s: How often it looks whether that ``iwz run`` is still this process's parent.
        grace_s: How long after the SIGTERM it sends itself SIGKILL.

    Returns:
        The watching thread (a daemon), or None when nothing is watched: no such variable, or a
        pid that is alive but not this process's parent (started by hand, or through a wrapper).
    """
    raw = os.environ.pop(SUPERVISOR_ENV, "")
    if not raw:
        return None
    pid = int(raw) if raw.isascii() and raw.isdigit() and len(raw) <= len(str(PID_MAX)) else 0
    if not 0 < pid <= PID_MAX:  # os.kill would overflow on a huge one
        logger.warning("%s=%r is not a process id: not watching it", SUPERVISOR_ENV, raw[:40])
        return None
    if os.getppid() != pid and _alive(pid):
        logger.info("%s=%d is not this process's parent: not watching it", SUPERVISOR_ENV, pid)
        return None

    def watch() -> None:
        while os.getppid() == pid:  # once gone, this process was handed to another parent
            time.sleep(poll_s)
        logger.warning("the iwz run that started this process (pid %d) is gone: stopping", pid)
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(grace_s)  # a process that stopped is gone with this thread
        logger.warning("still running %g s after: killing this process", grace_s)
        os.kill(os.getpid(), signal.SIGKILL)

    thread = threading.Thread(target=watch, name="supervisor-watch", daemon=True)
    thread.start()
    return thread


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs: not a zombie, which ``kill(pid, 0)`` still finds (an ``iwz
    run`` killed before this process looked, its own parent not having reaped it yet, is gone)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # someone else's
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return not Path("/proc/self").exists()  # gone meanwhile; or no /proc (not Linux): as kill said
    except OSError:
        return True
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def setup_logging(verbosity: int, role: str) -> None:
    """Configures logging for a process (``-v`` info, ``-vv`` debug)."""
    level = logging.WARNING if verbosity <= 0 else logging.INFO if verbosity == 1 else logging.DEBUG
    logging.basicConfig(level=level, format=f"%(asctime)s {role} %(levelname)s %(name)s: %(message)s")


@dataclass
class Process:
    """A started role process, as its ``run`` sees it.

    Attributes:
        args: Its parsed arguments.
        bus: The open bus (closed by :func:`start_role` when ``run`` returns).
        io: Its node handle; a stop signal sets ``io.stop`` and ``io.wake``.
        sim: The simulation name (a valid key chunk).
        name: This instance's name (liveliness).
        prog: How it names itself in messages (``iwz ROLE``).
    """

    args: argparse.Namespace
    bus: ZenohBus
    io: NodeIO
    sim: str
    name: str
    prog: str
    _on_stop: list[Callable[[], None]] = field(default_factory=list)

    def on_stop(self, callback: Callable[[], None]) -> None:
        """Also calls ``callback`` on a stop signal (at once when one has come already)."""
        self._on_stop.append(callback)
        if self.io.stop.is_set():
            callback()

    def _stop(self) -> None:
        self.io.wake.set()
        for callback in list(self._on_stop):
            callback()


@overload
def start_role(
    argv: Sequence[str] | None,
    *,
    role: str,
    description: str,
    epilog: str = ...,
    arguments: Callable[[argparse.ArgumentParser], None] | None = ...,
    warm_up: Callable[[], None] | None = ...,
    prepare: None = ...,
    run: Callable[[Process], int | None],
    name: Callable[[argparse.Namespace], str] | None = ...,
    name_help: str = ...,
    prog: str = ...,
    default_mode: str = ...,
) -> int: ...


@overload
def start_role(
    argv: Sequence[str] | None,
    *,
    role: str,
    description: str,
    epilog: str = ...,
    arguments: Callable[[argparse.ArgumentParser], None] | None = ...,
    warm_up: Callable[[], None] | None = ...,
    prepare: Callable[[argparse.Namespace], T],
    run: Callable[[Process, T], int | None],
    name: Callable[[argparse.Namespace], str] | None = ...,
    name_help: str = ...,
    prog: str = ...,
    default_mode: str = ...,
) -> int: ...


def start_role(
    argv: Sequence[str] | None,
    *,
    role: str,
    description: str,
    epilog: str = "",
    arguments: Callable[[argparse.ArgumentParser], None] | None = None,
    warm_up: Callable[[], None] | None = None,
    prepare: Callable[[argparse.Namespace], Any] | None = None,
    run: Callable[..., int | None],
    name: Callable[[argparse.Namespace], str] | None = None,
    name_help: str = "",
    prog: str = "",
    default_mode: str = "client",
) -> int:
    """Starts a role process: parse, log, warm up, prepare, join the bus, run, close.

    Args:
        argv: The arguments (``None``: the command line).
        role: The role (liveliness role, log name, and ``iwz ROLE`` in messages).
        description: What it does, for ``--help``.
        epilog: Examples, for ``--help`` (printed as written).
        arguments: Adds the role's own flags.
        warm_up: Called before joining (e.g. compiling kernels, so a first tick never waits).
        prepare: Turns the arguments into what ``run`` needs, before joining; an
            :class:`IwError` or ``ValueError`` it raises prints ``iwz ROLE: reason``, exit 2.
        run: The role's work, given the :class:`Process` (and what ``prepare`` made); returns
            an exit code or ``None`` (0).
        name: This instance's default name from the arguments, when ``--name`` is not given
            (default: the role).
        name_help: That default, as ``--help`` says it.
        prog: The program's name (default ``iwz ROLE``).
        default_mode: The Zenoh session mode by default.

    Returns:
        The exit code: 0, 2 for refused arguments or no bus, or what ``run`` returns.
    """
    prog = prog or f"iwz {role}"
    args = _parse(argv, prog, description, epilog, arguments, default_mode, name_help or role)
    setup_logging(args.verbose, prog.removeprefix("iwz "))
    watch_supervisor()  # before the warm-up: a launcher gone by then is seen at once
    if warm_up is not None:
        _warm(warm_up)
    try:
        sim = keys.chunk(args.sim)
        prepared = prepare(args) if prepare is not None else None
        bus = ZenohBus(net_from_args(args))
    except (IwError, ValueError) as e:
        print(f"{prog}: {e}", flush=True)
        return 2
    proc_name = args.name or (name(args) if name is not None else role)
    proc = Process(args, bus, NodeIO(bus, sim, role, proc_name), sim, proc_name, prog)
    install_stop_signals(proc.io.stop, proc._stop)
    stop_reports = proc.io.report_refusals()
    try:
        code = run(proc, prepared) if prepare is not None else run(proc)
    finally:
        stop_reports()
        bus.close()
    return code or 0


def _warm(warm_up: Callable[[], None]) -> None:
    """Runs a role's warm-up, saying how long it took when that was long."""
    t0 = time.monotonic()
    warm_up()
    if time.monotonic() - t0 > 1.0:
        logger.info("warmed up in %.1f s (kernels compiled; cached for later runs)", time.monotonic() - t0)


class _Formatter(argparse.HelpFormatter):
    """Fills prose to the terminal's width but keeps example lines (indented, or ``iwz ...``) as written."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        lines = []
        for line in text.splitlines():
            raw = line.startswith((" ", "iwz ")) or not line.strip()
            lines.append(indent + line if raw else super()._fill_text(line, width, indent))
        return "\n".join(lines)


def _parse(
    argv: Sequence[str] | None,
    prog: str,
    description: str,
    epilog: str,
    arguments: Callable[[argparse.ArgumentParser], None] | None,
    default_mode: str,
    name_help: str,
) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog=prog, description=description, epilog=epilog, formatter_class=_Formatter)
    if arguments is not None:
        arguments(p)
    p.add_argument("--name", default="", help=f"instance name (liveliness; default {name_help})")
    add_common_arguments(p, default_mode=default_mode)
    return p.parse_args(argv)
