"""``iwz run SCENARIO.toml``: the router and every role as a child process on this machine,
supervised, with a live status line, a summary, and an exit code from the scenario's criteria.

Exit codes: 0 every criterion met; 1 a criterion failed, or the recording was not finished; 2
the scenario or arguments are refused; 3 a role could not start; 70 iwz run itself failed (its
output says where; never read as a verdict); 130 interrupted.
"""

from __future__ import annotations

import logging
import os
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Sequence
from pathlib import Path

import msgspec

from iw_zenoh import keys
from iw_zenoh.bus import Inbox, ZenohBus
from iw_zenoh.bus.net import DEFAULT_PORT, NetConfig, free_port, port_in_use
from iw_zenoh.core.modes import Mode
from iw_zenoh.errors import IwError
from iw_zenoh.launch.args import build_parser, default_recording, scenario_from_args, scenario_sets
from iw_zenoh.launch.child import Child, stop_in_order
from iw_zenoh.launch.plan import RunPlan
from iw_zenoh.launch.restarts import MAX_RESTARTS, Restarts
from iw_zenoh.launch.secure_run import LAUNCHER, refuse_ros2
from iw_zenoh.launch.signals import stop_on_signals
from iw_zenoh.launch.summary import print_summary
from iw_zenoh.launch.tally import Tally
from iw_zenoh.launch.waits import wait_listening, wait_roles
from iw_zenoh.messages import Control, Event, WorldInfo, WorldState, decode, encode
from iw_zenoh.nodes.recorder import CANNOT_WRITE
from iw_zenoh.nodes.world_options import world_options
from iw_zenoh.nodes.world_seal import SEAL_ENV, new_key, sealed
from iw_zenoh.process.options import options_argument
from iw_zenoh.process.runtime import SUPERVISOR_ENV, setup_logging
from iw_zenoh.scenario.file import load_scenario
from iw_zenoh.scenario.shipped import resolve_scenario
from iw_zenoh.scenario.tables import Scenario

__all__ = ["Child", "Launcher", "main", "world_options"]

logger = logging.getLogger(__name__)


STATES_KEPT = 1024  # states waiting for the launcher's look, 0.1 s apart (a lock-step run at 100x makes 100)


class Launcher:
    """Starts, watches and stops a scenario's processes.

    Args:
        scenario: The scenario.
        port: Router port on 127.0.0.1 (0: 7447, or a free one when 7447 is taken).
        sim: Simulation name.
        log_dir: Where each role's log goes.
        status: Print a live status line.
    """

    def __init__(
        self,
        scenario: Scenario,
        *,
        port: int = 0,
        sim: str = "default",
        log_dir: Path | None = None,
        status: bool = True,
        record: Path | None = None,
        secure: bool = False,
        ids: Path | None = None,
        host: str = "",
        connect: str = "",
        listen: str = "",
    ) -> None:
        if secure:
            refuse_ros2(scenario)  # its ROS 2 keys are refused by the router: it could do nothing
        self.sc = scenario
        self.sim = keys.chunk(sim)
        if listen:
            port = int(listen.rsplit(":", 1)[1])
        if port == 0:
            port = DEFAULT_PORT if not port_in_use(DEFAULT_PORT) else free_port()
        self.port = port
        self.listen = listen or f"{'tls' if secure else 'tcp'}/127.0.0.1:{port}"
        self.endpoint = connect or self.listen.replace("0.0.0.0", "127.0.0.1")
        self.remote_router = bool(connect)
        self.host = host
        self.log_dir = log_dir or Path(tempfile.mkdtemp(prefix=f"iwz-{scenario.name}-"))
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.ids = (ids or self.log_dir / "ids") if secure else None  # every process's identity (docs/security.md)
        self.world_seen = self.world_alive = False  # a host without the world ends when it is gone
        self.status = status
        self.record = record
        self.children: list[Child] = []
        self.tally = Tally()
        self.restarts = Restarts()
        self.failed: Child | None = None  # the child that could not start, which ended the run
        self.record_cut: float | None = None  # when (sim s) the recorder could no longer write its file
        self.bus: ZenohBus | None = None  # the launcher's own session, from the router's start
        self._inboxes: tuple[Inbox, Inbox, Inbox] | None = None
        self.forged_infos = 0  # world descriptions ignored: not sealed by the world started
        self.stale_infos = 0  # ... sealed by it, but older than the one kept (a replayed recording)
        self.stop_event = threading.Event()
        # each child stops by itself if this launcher is ever gone without stopping it (a kill)
        self.env = dict(os.environ, PYTHONUNBUFFERED="1", **{SUPERVISOR_ENV: str(os.getpid())})
        # the world alone is given it (Child.start): its descriptions are known from forgeries
        self.seal = new_key()
        self.env[SEAL_ENV] = self.seal
        self.world_options = world_options(scenario)
        self.tally.running = not self.world_options[0].start_paused

    def _net(self) -> NetConfig:
        """How the launcher itself joins (secured: as ``launcher``, an operator)."""
        return NetConfig(connect=(self.endpoint,), identity=str(self.ids / LAUNCHER) if self.ids else None)

    def plan(self) -> None:
        """Builds the list of processes this host starts (:class:`RunPlan`), each role handed its
        options as a typed Struct; secured, writes every identity and the policy."""
        plan = RunPlan(
            self.sc,
            self.world_options,
            sim=self.sim,
            listen=self.listen,
            endpoint=self.endpoint,
            log_dir=self.log_dir,
            ids=self.ids,
            record=self.record,
        )
        self.children = plan.build(host=self.host, remote_router=self.remote_router)

    def _wait_router(self, timeout_s: float = 15.0) -> bool:
        router = next(c for c in self.children if c.role == "router")
        return wait_listening(router, self.port, self.endpoint.rsplit(":", 1)[0].split("/")[-1], timeout_s)

    def start(self) -> None:
        """Starts the router (unless another host runs it), waits for it, then every other role.

        Raises:
            IwError: When the router does not come up.
        """
        self.plan()
        rest = [c for c in self.children if c.role != "router"]
        for router in self.children[: len(self.children) - len(rest)]:
            router.start(self.env)
            if not self._wait_router():
                raise IwError(f"the router did not start on {self.endpoint}:\n{router.tail()}")
        # the launcher listens before any other role starts: it hears every registration (who
        # drives each robot) and the world's description, what a restarted world resumes from
        self.bus = ZenohBus(self._net())
        self._inboxes = self.observe(self.bus)
        if rest and rest[0].role == "record":
            rest[0].start(self.env)  # first, and heard from, so it misses nothing of the run
            if not self._wait_roles({"recorder": 1}, timeout_s=30.0) and not self.stop_event.is_set():
                raise IwError(f"the recorder did not start:\n{rest[0].tail()}")
            rest = rest[1:]
        if self.stop_event.is_set():
            return  # stopped meanwhile (SIGTERM, SIGHUP): nothing more to start, and nothing failed
        agents = [c for c in rest if c.role in ("agent", "bridge")]  # a bridge's robots register too
        for c in rest:
            if c not in agents:
                c.start(self.env)
        if agents:
            # agents last, once collision, every sensors shard and the radio are up: a chair
            # registered before would get no readings for its first ticks (motors zeroed by the
            # watchdog) or be held still (a sensors process compiles its kernel on a first run)
            roles = {"collision": 1, "sensors": self.sc.roles.sensors_shards}
            roles |= {"radio": 1} if any(c.role == "radio" for c in rest) else {}
            up = self._wait_roles(roles, timeout_s=60.0)
            if self.failed is not None or self.stop_event.is_set():
                return  # supervise() ends the run at once
            if not up:
                print(
                    f"iwz run: collision and sensors not all up after 60 s; starting the agents anyway ({self.log_dir})"
                )
            for c in agents:
                c.start(self.env)

    def _wait_roles(self, roles: dict[str, int], timeout_s: float) -> bool:
        """Waits until at least ``roles[role]`` processes of each role are alive."""
        return wait_roles(self._net(), self.sim, roles, timeout_s, stop=self.stop_event, failed=self._start_failed)

    def observe(self, bus: ZenohBus) -> tuple[Inbox, Inbox, Inbox]:
        """Subscribes to state, events and the world's description, and watches liveliness
        (agents alive; restarted roles back)."""
        # every state, not the newest: a goal is reached, a door closes, at a tick, and a lock-step
        # run makes many ticks between two looks (the verdict was that of whichever state was
        # newest when it looked, so two runs of the same seed reported different times)
        states = Inbox(maxlen=STATES_KEPT)
        events = Inbox()  # every event counts (a removal, a hold): INBOX_KEPT, losses logged
        infos = Inbox(maxlen=1, newest_only=True)
        bus.subscribe(keys.state(self.sim), states)
        bus.subscribe(keys.all_events(self.sim), events)
        bus.subscribe(keys.info(self.sim), infos)

        def on_alive(key: str, alive: bool) -> None:
            parts = keys.alive_parts(key)
            if parts and parts[0] == "agent":
                (self.tally.agents_alive.add if alive else self.tally.agents_alive.discard)(parts[1])
            if parts and parts[0] == "world":
                self.world_seen, self.world_alive = self.world_seen or alive, alive
            if parts and alive:
                for c in self.children:
                    c.seen = c.seen or c.owns_token(parts[0], parts[1])
            if parts and alive:
                back = self.restarts.on_alive(self.children, parts[0], parts[1], time.monotonic())
                if back:
                    self._say(back)

        bus.watch_alive(keys.all_alive(self.sim), on_alive)
        return states, events, infos

    def _update(self, states: Inbox, events: Inbox, infos: Inbox) -> None:
        for _, data, _ in infos.drain():
            try:
                info = decode(data, WorldInfo)
            except IwError:
                continue
            if not sealed(info, bytes.fromhex(self.seal)):  # not its world's: a restarted world
                self.forged_infos += 1  # resumes from the last description it sent
                if self.forged_infos == 1:
                    logger.warning("a world description not from the world iwz run started was ignored")
            elif self.tally.info is not None and info.revision < self.tally.info.revision:
                self.stale_infos += 1  # its world's, but older than one kept: a replay (or late)
                if self.stale_infos == 1:
                    logger.warning(
                        "a world description of revision %d, older than the %d kept, was ignored (a replay?)",
                        info.revision,
                        self.tally.info.revision,
                    )
            else:
                self.tally.info = info
        for _, data, _ in events.drain():
            try:
                self.tally.on_event(decode(data, Event))
            except IwError:
                continue
        for _, data, _ in states.drain():
            try:
                self.tally.on_state(decode(data, WorldState), self.sc.criteria.reach, self.sc.criteria.doors)
            except IwError:
                continue

    def supervise(self, bus: ZenohBus) -> int:
        """Watches the run until the world ends it, a criterion stops it, or Ctrl-C."""
        inboxes = self._inboxes if self._inboxes is not None and bus is self.bus else self.observe(bus)
        started = time.monotonic()
        last_print = 0.0
        world = next((c for c in self.children if c.role == "world"), None)
        agents = [c for c in self.children if c.role == "agent"]
        limit = self.sc.world.duration_s * (1.0 if self.sc.world.mode == Mode.REALTIME else 5.0) + 60.0
        code: int | None = None
        try:
            while code is None and not self.stop_event.is_set():
                self.stop_event.wait(0.1)
                self._update(*inboxes)
                code = self._ended(bus, world)
                if code is None:
                    code = self._restart_lost()
                if code is None and time.monotonic() - started > limit:
                    self._say(f"wall-clock limit of {limit:.0f} s reached: stopping")
                    code = 0
                now = time.monotonic()
                if code is None and self.status and now - last_print >= (1.0 if sys.stdout.isatty() else 5.0):
                    last_print = now
                    self._status_line(now - started, agents)
        except KeyboardInterrupt:
            code = 130
        if code != 3 and sys.stdout.isatty() and self.status:
            print()
        return code or 0

    def _ended(self, bus: ZenohBus, world: Child | None) -> int | None:
        """0 when every goal is reached (the world is told to stop) or the world ended; 3 when it failed."""
        crit = self.sc.criteria
        if (
            crit.reach
            and crit.stop_when_reached
            and all(r.robot in self.tally.reached for r in crit.reach)
            and self.tally.doors.settled(crit.doors)
        ):
            self._say("every goal reached" + (" and every door opened and closed" if crit.doors else "") + ": stopping")
            bus.publish(keys.control(self.sim), encode(Control(command="stop")))
            if world is not None and world.proc is not None:
                try:
                    world.proc.wait(10)
                except subprocess.TimeoutExpired:
                    self._say("the world did not stop by itself")
            return 0
        if world is None:  # another host runs it: the run is over when it is gone
            return 0 if self.world_seen and not self.world_alive else None
        if not world.alive() and world.proc is not None and world.proc.returncode == 0:
            return 0  # the world ended the run (its duration, a stop); one that died is restarted
        return None

    def _start_failed(self) -> bool:
        """Whether a child could not start (see :meth:`Restarts.could_not_start`): the first one
        found is said on stderr, its name and its error, and kept in ``failed``."""
        for c in self.children:
            if self.failed is None and c.proc is not None and not c.alive() and not c.expected_exit:
                code = c.proc.returncode
                if self.restarts.could_not_start(c, code):
                    self.failed, c.expected_exit = c, True
                    if sys.stdout.isatty():
                        print()
                    print(f"iwz run: {c.name} could not start (exit {code}): {c.error()}", file=sys.stderr, flush=True)
                    print(f"iwz run: its log: {c.log}", file=sys.stderr, flush=True)
        return self.failed is not None

    def _restart_lost(self) -> int | None:
        """Restarts every lost role that may be restarted, once its wait is over; 3 when a role
        could not start, or when the router or the world is lost for good."""
        if self._start_failed():
            return 3
        now = time.monotonic()
        for c in self.children:
            if c.alive() or c.expected_exit or c.proc is None:
                continue
            code = c.proc.returncode
            if c.role == "world" and code == 0:
                continue  # it ended the run (its duration, a stop) between _ended's look and this: _ended's next
            if self.restarts.restartable(c, code) and c.restarts < MAX_RESTARTS:
                if c.name not in self.restarts.lost_at:
                    self._say(f"{c.name} exited with {code}; restarting it ({c.restarts + 1}/{MAX_RESTARTS})")
                if self.restarts.due(c, now):
                    self._restart(c)
                continue
            c.expected_exit = True
            if c.role == "record" and code == CANNOT_WRITE:
                self.record_cut = self.tally.sim_s  # the run goes on, unrecorded: the summary fails it
            if code or c.role not in ("agent",):
                self._say(f"{c.name} exited with {code}:\n{c.tail()}")
            if c.role in ("router", "world"):
                return 3
        return None

    def _restart(self, c: Child) -> None:
        """Starts a lost child again: the router on the same port (every client finds it again by
        itself), the world from the last committed state the launcher heard, the recorder into
        the next part of the run's recording (its ``--continue RUN``). Only the router is waited
        for: the run goes on while the others come up (a recorder is not heard from as at the
        start: what the bus carries meanwhile waits for it in its queue once it listens)."""
        if c.role == "world":
            snap = self.tally.snapshot()
            options = msgspec.structs.replace(self.world_options[0], resume=snap)
            c.set_option("--options", options_argument(options, c.log.with_suffix(".options.json")))
            c.options = options
            if snap is None:
                self._say("the world's description was never heard: the new world starts afresh")
            else:
                self._say(f"the new world resumes at tick {snap.tick} with {len(snap.robots)} robots")
        if c.role == "record":
            self._say("the new recorder continues the recording in its next part")
        self.restarts.restarted(c)
        c.start(self.env)
        if c.role == "router" and not self._wait_router(timeout_s=10.0):
            self._say(f"the router did not listen again on {self.endpoint} within 10 s")

    def _status_line(self, wall_s: float, agents: list[Child]) -> None:
        line = self.tally.status(wall_s, sum(1 for c in agents if c.token in self.tally.agents_alive), len(agents))
        if sys.stdout.isatty():
            print("\r" + line.ljust(110), end="", flush=True)
        else:
            print(line, flush=True)

    def _say(self, text: str) -> None:
        if sys.stdout.isatty():
            print()
        print(f"iwz run: {text}", flush=True)

    def shutdown(self, timeout_s: float = 8.0) -> None:
        """Stops every child: agents first, the router last; SIGKILL after ``timeout_s``. A
        recorder that did not end with 0 (killed, crashed while finishing, or a restarted one
        stopped before it could open its part) left its file cut off: the run says so (exit 1)."""
        stop_in_order(self.children, timeout_s)
        for c in self.children:  # (one that never started, or could not, is said as such: not here)
            if c.role != "record" or c.proc is None or not c.seen or c is self.failed:
                continue
            if c.proc.returncode != 0 and self.record_cut is None:
                self.record_cut = self.tally.sim_s
                self._say(f"{c.name} did not finish the recording (exit {c.proc.returncode}):\n{c.tail()}")

    def verdict(self) -> tuple[bool, list[str]]:
        """Whether the criteria are met, and a line per criterion."""
        return self.tally.verdict(self.sc.criteria)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz run``."""
    args = build_parser().parse_args(argv)
    setup_logging(args.verbose, "run")
    try:
        sc = scenario_from_args(load_scenario(resolve_scenario(args.scenario), scenario_sets(args)), args)
        launcher = Launcher(
            sc,
            port=args.port,
            sim=args.sim,
            log_dir=Path(args.log_dir) if args.log_dir else None,
            status=not args.no_status,
            record=None if args.no_record else Path(args.record) if args.record else default_recording(sc.name),
            secure=args.secure or bool(sc.security and sc.security.enabled),
            ids=Path(args.ids) if args.ids else None,
            host=args.host,
            connect=args.connect,
            listen=args.listen,
        )
    except (IwError, ValueError) as e:
        print(f"iwz run: {e}")
        return 2
    print(
        f"iwz run: scenario {sc.name!r} on {sc.world.map.name}, {sc.world.mode}, {sc.robots} robots, "
        f"router {launcher.endpoint}{' (secured)' if launcher.ids else ''}, logs in {launcher.log_dir}",
        flush=True,
    )

    stop_on_signals(launcher.stop_event)
    try:
        return _run_and_judge(launcher)
    except Exception:  # iwz run's own failure (its children stopped all the same): 1 would read as a verdict
        logger.exception("iwz run failed")
        return 70


def _run_and_judge(launcher: Launcher) -> int:
    """Starts and supervises the run, stops every child in order whatever happened, and judges
    it: the exit code (see the module doc)."""
    code = 0
    try:
        launcher.start()
        assert launcher.bus is not None
        code = launcher.supervise(launcher.bus)
    except IwError as e:
        print(f"iwz run: {e}")
        code = 3
    except KeyboardInterrupt:
        code = 130
    finally:
        try:
            if launcher.bus is not None:
                launcher.bus.close()
        finally:
            launcher.shutdown()  # whatever happened: every child stopped and waited for, the recording finished
    if launcher.failed is not None:
        return 3  # no verdict: the run never ran
    ok = print_summary(
        launcher.tally,
        launcher.sc.criteria,
        recovered=launcher.restarts.recovered,
        record=launcher.record,
        record_cut=launcher.record_cut,
    )
    if code:
        return code
    return 0 if ok else 1
