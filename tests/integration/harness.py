"""Real processes on a real Zenoh router: spawn roles, talk to them, stop them by pid."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

from iw_zenoh import keys
from iw_zenoh.bus import Inbox, ZenohBus
from iw_zenoh.bus.net import NetConfig, free_port, port_in_use
from iw_zenoh.messages import Event, Message, RegisterReply, RegisterRequest, RobotSpecMsg, WorldState, decode, encode

M = TypeVar("M", bound=Message)
ROUTER_TRIES = 3  # ports tried for a test's router (one chosen here may be taken before it binds)
ROOT = Path(__file__).resolve().parents[2]
MAPS = ROOT / "maps"
SCENARIOS = MAPS / "scenarios"


@dataclass
class Proc:
    """A spawned role."""

    name: str
    popen: subprocess.Popen[bytes]
    log: Path

    def kill(self, sig: int = signal.SIGKILL) -> None:
        """Signals it (SIGKILL by default) and reaps it."""
        if self.popen.poll() is None:
            self.popen.send_signal(sig)
            try:
                self.popen.wait(10)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait(5)

    def output(self) -> str:
        """What it printed."""
        return self.log.read_text(errors="replace") if self.log.exists() else ""


@dataclass
class Net:
    """A router on a free loopback port and the processes of one test."""

    tmp: Path
    sim: str = "t"
    port: int = 0
    procs: list[Proc] = field(default_factory=list)
    buses: list[ZenohBus] = field(default_factory=list)
    prefix: list[str] = field(default_factory=list)
    endpoint_host: str = "127.0.0.1"
    scheme: str = "tcp"  # tls: a secured router (start_secured_router)

    @property
    def endpoint(self) -> str:
        """The router's endpoint."""
        return f"{self.scheme}/{self.endpoint_host}:{self.port}"

    def spawn(
        self, role: str, *args: str, name: str | None = None, prefix: list[str] | None = None, connect: bool = True
    ) -> Proc:
        """Starts ``iwz ROLE ARGS`` as a child process connected to the router."""
        name = name or f"{role}-{len(self.procs)}"
        extra = ["--sim", self.sim, "-e", self.endpoint] if connect else ["--sim", self.sim]
        argv = [
            *(prefix if prefix is not None else self.prefix),
            sys.executable,
            "-m",
            "iw_zenoh.cli",
            role,
            *args,
            *extra,
        ]
        return self.launch(name, argv)

    def launch(self, name: str, argv: list[str]) -> Proc:
        """Starts ``argv`` as a child process logging to ``NAME.log``; stopped by :meth:`close`."""
        log = self.tmp / f"{name}.log"
        with log.open("wb") as f:
            p = subprocess.Popen(
                argv,
                stdout=f,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                env=dict(os.environ, PYTHONUNBUFFERED="1"),
            )
        proc = Proc(name, p, log)
        self.procs.append(proc)
        return proc

    def start_router(
        self, listen: str | None = None, prefix: list[str] | None = None, extra: Sequence[str] = ()
    ) -> Proc:
        """Starts the router and waits until it says it listens on its port (a port chosen here
        and taken meanwhile, by a parallel test's router or a connection's own port: another).

        The port in use is not enough: it may be another test's router, which this test's
        processes would then join (two worlds of simulation ``t`` answering each other)."""
        chosen = not self.port
        for attempt in range(1, ROUTER_TRIES + 1):
            if chosen:
                self.port = free_port()
            argv = [
                *(prefix or []),
                sys.executable,
                "-m",
                "iw_zenoh.cli",
                "router",
                "--sim",
                self.sim,
                "--listen",
                listen or self.endpoint,
                *extra,
            ]
            proc = self.launch("router" if attempt == 1 else f"router-{attempt}", argv)  # each its own log
            if prefix is not None or self._listens(proc) or not chosen or attempt == ROUTER_TRIES:
                break
        if prefix is None:
            assert self._listens(proc), f"router died (its port {self.port} taken?):\n{proc.output()}"
        return proc

    def start_secured_router(self, ids: Path, *extra: str) -> Proc:
        """A secured run's router (mutual TLS as ``ids/router``, enforcing ``ids/policy.toml``)
        on a port of its own, as :meth:`start_router`; :attr:`endpoint` is then its ``tls/`` one."""
        self.scheme = "tls"
        return self.start_router(
            extra=["--identity", str(ids / "router"), "--policy", str(ids / "policy.toml"), *extra]
        )

    def _listens(self, proc: Proc) -> bool:
        """Waits until the router says it listens on :attr:`port` (True) or dies (False)."""
        said, deadline = re.compile(rf":{self.port}(?!\d)"), time.monotonic() + 20
        while not (port_in_use(self.port) and any(said.search(line) for line in _listening(proc.output()))):
            if proc.popen.poll() is not None:
                return False
            assert time.monotonic() < deadline, f"router did not listen in 20 s:\n{proc.output()}"
            time.sleep(0.02)  # polling its log: there is no event to wait on
        return True

    def client(self) -> ZenohBus:
        """A Zenoh client session of the test itself."""
        bus = ZenohBus(NetConfig(connect=(self.endpoint,)))
        self.buses.append(bus)
        return bus

    def close(self) -> None:
        """Stops every process (by pid) and session."""
        for b in self.buses:
            b.close()
        for p in reversed(self.procs):
            p.kill(signal.SIGTERM)


OPEN_LAB = '<Lab Name="open" Width="40" Height="10"/>'  # a 40 x 10 m lab with no wall inside


def watch(net: Net) -> tuple[ZenohBus, Inbox, Inbox]:
    """The test's own session on the run, with its inboxes of every event and of the newest state
    (opened before anything starts: nothing the run says is missed)."""
    bus = net.client()
    return bus, subscribe(bus, keys.all_events(net.sim)), subscribe(bus, keys.state(net.sim), maxlen=1)


def start_world(net: Net, *roles: str, lab: str = OPEN_LAB) -> None:
    """Writes ``lab`` as the run's map, starts the world on it, then each of ``roles`` (collision,
    sensors, radio...), each its own process named after its role."""
    (net.tmp / "lab.xml").write_text(lab)
    net.spawn("world", str(net.tmp / "lab.xml"), name="world")
    for role in roles:
        net.spawn(role, name=role)


def scenario_in(tmp: Path, name: str, toml: str) -> Path:
    """Writes scenario ``NAME.toml`` in ``tmp`` beside the lab it names, ``lab.xml`` (open, 20 x
    10 m), and ``grid.xml`` (one start place, (3, 5) facing east); its path."""
    (tmp / "lab.xml").write_text('<Lab Name="open" Width="20" Height="10"/>')
    (tmp / "grid.xml").write_text('<Grid><Position X="3" Y="5" Dir="0"/></Grid>')
    path = tmp / f"{name}.toml"
    path.write_text(toml)
    return path


def stop_run(p: subprocess.Popen[str]) -> tuple[str, str]:
    """Stops an ``iwz run`` launcher as Ctrl-C does (it stops every process it started, in order;
    killed, its processes stop by themselves, all at once), killing it only if it is still up 30 s
    later; its output."""
    if p.poll() is None:
        p.send_signal(signal.SIGINT)
    try:
        out, err = p.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        p.kill()
        out, err = p.communicate()
    return out or "", err or ""


def iwz_run_argv(
    scenario: Path, tmp: Path, sim: str, *, record: Path | None = None, extra: tuple[str, ...] = ()
) -> list[str]:
    """``iwz run SCENARIO`` on a free router port, logs in ``tmp``, recorded to ``record`` (or not)."""
    argv = [sys.executable, "-m", "iw_zenoh.cli", "run", str(scenario), "--port", str(free_port()), "--no-status"]
    argv += ["--sim", sim, "--log-dir", str(tmp), *(["--record", str(record)] if record else ["--no-record"]), *extra]
    return argv


def subscribe(bus: ZenohBus, key_expr: str, maxlen: int | None = None) -> Inbox:
    """A test inbox on a key expression (``maxlen``: the newest kept; None: a million, all a test sees)."""
    box = Inbox(maxlen=maxlen if maxlen is not None else 1_000_000)
    bus.subscribe(key_expr, box)
    return box


def wait_msg(box: Inbox, kind: type[M], pred: Callable[[M], bool] = lambda m: True, timeout_s: float = 20.0) -> M:
    """The first message of ``kind`` in ``box`` satisfying ``pred``, waiting up to ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while True:
        left = deadline - time.monotonic()
        assert left > 0, f"no {kind.__name__} matching within {timeout_s} s"
        d = box.get(timeout_s=left)
        if d is None:
            continue
        try:
            m = decode(d[1], kind)
        except Exception:
            continue
        if pred(m):
            return m


def wait_event(
    box: Inbox,
    kind: str,
    timeout_s: float = 20.0,
    pred: Callable[[Event], bool] = lambda e: True,
    missing: Callable[[], object] | None = None,
) -> Event:
    """The first event of ``kind``; ``missing()`` says what was still awaited if none comes."""
    try:
        return wait_msg(box, Event, lambda e: e.kind == kind and pred(e), timeout_s)
    except AssertionError as e:
        raise AssertionError(f"{e}; still waiting for {missing()}" if missing else str(e)) from None


def wait_alive(bus: ZenohBus, key: str, timeout_s: float = 30.0) -> None:
    """Waits until a liveliness token matching ``key`` exists."""
    up = threading.Event()
    bus.watch_alive(key, lambda _k, alive: up.set() if alive else None)
    assert up.wait(timeout_s), f"{key} did not come alive within {timeout_s} s"


_TOKENS: set[tuple[ZenohBus, str]] = set()  # the agents' tokens the tests' buses declared


def register(bus: ZenohBus, sim: str, spec: RobotSpecMsg, agent: str = "", timeout_s: float = 20.0) -> RegisterReply:
    """Registers a robot from the test, retrying until a world answers. For a named ``agent``
    the test's bus first declares that agent's liveliness token, as a real agent host does (the
    world removes the robots of an agent whose token never appears within its grace period)."""
    if agent and (bus, agent) not in _TOKENS:
        _TOKENS.add((bus, agent))
        bus.token(keys.alive(sim, "agent", agent))  # lives as long as the bus
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        got = bus.query(keys.register(sim), encode(RegisterRequest(spec=spec, agent=agent)), timeout_s=1.0)
        if got:
            return decode(got[0], RegisterReply)
    raise AssertionError("no world answered the registration")


def state_of(msg: WorldState, robot_id: int) -> tuple[float, float, float, bool]:
    """x, y, heading, collided of one robot in a state message."""
    i = msg.ids.index(robot_id)
    return msg.x[i], msg.y[i], msg.heading[i], msg.collided[i]


def _listening(output: str) -> list[str]:
    """The router's "listening on" lines in its output."""
    return [line for line in output.splitlines() if "listening on" in line]
