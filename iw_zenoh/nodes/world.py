"""``iwz world MAP``: the world process (see :mod:`iw_zenoh.sim.world` for the logic).

Wiring: registration and info queryables, actions / pose reports / control / verdict inboxes,
liveliness of collision processes and agents; then the tick loop in real time or lock-step.
"""

from __future__ import annotations

import argparse
import logging
import time
from collections import deque
from collections.abc import Callable, Sequence

from iw_zenoh import keys
from iw_zenoh.bus import Bus, PendingQuery
from iw_zenoh.bus.clock import Clock, WallClock
from iw_zenoh.bus.fairbox import FairInbox
from iw_zenoh.bus.wake import CountedWake
from iw_zenoh.core import drive
from iw_zenoh.core.lab import Grid
from iw_zenoh.core.modes import Mode
from iw_zenoh.errors import IwError
from iw_zenoh.maps import load_grid, load_lab
from iw_zenoh.messages import (
    ActionBatch,
    Actions,
    Control,
    Event,
    EventKind,
    LaggardData,
    PoseReport,
    RefusedData,
    RegisterReply,
    RegisterRequest,
    Verdict,
    decode,
    encode,
)
from iw_zenoh.nodes.world_options import WorldOptions, add_arguments, parse_obstacle
from iw_zenoh.nodes.world_seal import seal, seal_key
from iw_zenoh.process.runtime import NodeIO, Process, options_from_args, start_role
from iw_zenoh.sim.config import MS, WorldConfig, WorldSettings
from iw_zenoh.sim.registry import MAX_ROBOTS
from iw_zenoh.sim.resume import resume
from iw_zenoh.sim.world import WorldCore
from iw_zenoh.ticks import too_far_ahead

__all__ = ["WorldOptions", "add_arguments", "main", "parse_obstacle", "prepare", "run", "world_config"]

logger = logging.getLogger(__name__)

# the roles that keep the world's description from its publication (nodes/info.py, the radio):
# one that comes alive is sent it again, since a publication is not kept for late joiners
INFO_READERS = frozenset({"collision", "sensors", "radio"})
UNKNOWN_EVERY_NS = 1_000_000_000  # messages for a robot the world does not have: one event a second
UNKNOWN_KEPT = 1_000  # robots remembered for that (forged ids by the million cost no memory)
# a flood of registrations does not stop the clock: a pass answers them for this long (one at
# least), the rest wait for the next; past REGISTRATIONS_KEPT waiting, the newest are refused
REGISTRATIONS_A_PUMP_NS = 20_000_000
REGISTRATIONS_KEPT = 4_096
BUSY = "the world has too many registrations waiting; ask again in a moment"
BATCHES_KEPT = 4_096  # agent hosts' keys with action batches waiting, at most
PER_KEY_KEPT = 16  # the newest actions (or batches) of one robot's (or agent's) key waiting, at most
FIRST_VERDICT_NS = 10_000_000_000  # a legacy run's first step waits this long for its verdict (not held)
LEGACY_VERDICT_NS = 1_000_000_000  # ... and every later step this long: late, as the legacy's timer, not held


class _World:
    """The world's I/O loop around a :class:`WorldCore`."""

    def __init__(self, bus: Bus, core: WorldCore, clock: Clock, name: str, io: NodeIO | None = None) -> None:
        self.core = core
        self.clock = clock
        sim = core.cfg.sim
        self.io = io or NodeIO(bus, sim, "world", name)
        # lock-step: a tick's actions wake the loop once enough are in to complete it (see _await_actions)
        self.actions_wake = CountedWake(self.io.wake)
        # each robot's key and each agent's batch key keeps its newest 16 waiting (each robot's
        # newest command is what applies): a sender flooding its own key costs the loop 16
        # messages a pass and never pushes another's out (a host's batch holds every robot's
        # command of a tick, a thousand chairs: ~15 kB; 4,096 agents' keys at most); every robot
        # the world may hold has its place, and keys of robots it does not hold (a forger's
        # invented ids) take a few places of their own, never a held robot's
        self.actions = FairInbox(
            PER_KEY_KEPT,
            wake=self.actions_wake,
            keys_kept=MAX_ROBOTS,
            known=self._holds,
            name="the world's actions inbox",
        )
        bus.subscribe(keys.all_actions(sim), self.actions)
        self.batches = FairInbox(
            PER_KEY_KEPT, wake=self.io.wake, keys_kept=BATCHES_KEPT, name="the world's action batches inbox"
        )
        bus.subscribe(keys.all_agent_actions(sim), self.batches)
        self.reports = self.io.inbox(keys.all_pose_reports(sim))
        self.control = self.io.inbox(keys.control(sim))
        self.verdicts = self.io.inbox(keys.verdict(sim))
        self.register_q = bus.serve(keys.all_registers(sim))  # the shared key and each agent's own
        self._registrations: deque[PendingQuery] = deque()  # asked, not yet answered (a flood waits here)
        self.info_q = bus.serve(keys.info(sim))
        self.alive_changes: list[tuple[str, bool]] = []
        self._unknown: dict[int, int] = {}  # robot the world does not have -> when last reported
        self._info_revision = -1
        self.seal_key = seal_key()  # iwz run's, so that it knows its world's description from a forgery
        bus.watch_alive(keys.all_alive(sim), self._on_alive)
        self.io.alive()

    def _answer_info(self) -> None:
        """Answers late joiners' info queries (also while a tick waits for its verdict)."""
        pending = self.info_q.poll()
        if pending:
            data = encode(seal(self.core.info(), self.seal_key))
            for q in pending:
                q.reply(data)

    def _publish_info(self) -> None:
        """Publishes the world's description whenever it changed (recorders, replays, viewers)."""
        if self.core.revision != self._info_revision:
            self._info_revision = self.core.revision
            self.io.send(keys.info(self.core.cfg.sim), seal(self.core.info(), self.seal_key))

    def _holds(self, key: str) -> bool:
        """Whether a robot's key is one of a robot the world holds (asked on the bus's thread: a
        look-up in the roster the loop keeps)."""
        return keys.robot_id_of(key) in self.core.registry.entries

    def _on_alive(self, key: str, alive: bool) -> None:
        self.alive_changes.append((key, alive))  # list.append is atomic; drained by the loop
        self.io.wake.set()

    def pump(self) -> None:
        """Handles every input waiting now (not verdicts: the tick takes those)."""
        now = self.clock.now_ns()
        core, io = self.core, self.io
        self._take_alive(now)
        io.send_all(core.overdue(now))  # once a pass (not in begin_tick): a paused world's too
        self._registrations.extend(self.register_q.poll())
        answered = 0
        while len(self._registrations) > REGISTRATIONS_KEPT:  # the newest are told to ask again
            self._registrations.pop().reply(encode(RegisterReply(ok=False, reason=BUSY)))
        budget_end = self.clock.now_ns() + REGISTRATIONS_A_PUMP_NS
        while self._registrations and (budget_end > self.clock.now_ns() or not answered):
            answered += 1
            q = self._registrations.popleft()
            try:
                req = decode(q.payload, RegisterRequest)
            except IwError as e:
                io.event(
                    EventKind.REFUSED,
                    f"registration that does not decode: {e}",
                    RefusedData(),
                    key=keys.register(core.cfg.sim),
                )
                q.reply(encode(RegisterReply(ok=False, reason=f"the request does not decode: {e}")))
                continue
            asker = keys.register_agent_of(q.key)
            if asker and asker != req.agent:  # the router lets only that agent ask on its key
                why = f"a registration for agent {req.agent!r} on agent {asker!r}'s key"
                io.event(EventKind.REFUSED, why, RefusedData(name=req.spec.name, agent=req.agent), key=q.key)
                q.reply(encode(RegisterReply(ok=False, reason=why)))
                continue
            reply, out = core.register(req, now)
            q.reply(encode(reply))
            io.send_all(out)
        self._answer_info()
        for d in self.control.drain():
            msg = io.decode(d, Control)
            if msg is not None:
                io.send_all(core.on_control(msg))
        self._take_actions(now)
        self._take_batches(now)
        for d in self.reports.drain():
            r = io.decode(d, PoseReport)
            if r is not None and self._robot_message(d[0], r.robot_id, r.tick, now):
                core.on_pose_report(r, now)
        io.flush_refusals()

    def _take_alive(self, now: int) -> bool:
        """Takes the liveliness changes waiting; whether a collision process was lost among them."""
        lost = False
        while self.alive_changes:
            key, alive = self.alive_changes.pop(0)
            parts = keys.alive_parts(key)
            if parts:
                lost |= parts[0] == "collision" and not alive
                if alive and parts[0] in INFO_READERS:
                    self._info_revision = -1  # published again at the next pass (_publish_info)
                self.io.send_all(self.core.on_alive(parts[0], parts[1], alive, now))
        return lost

    def _robot_message(self, key: str, robot_id: int, tick: int, now: int) -> bool:
        """Whether a robot's message may be acted on: on its own key, for a robot the world knows,
        its tick within the window; otherwise it is refused with a bad-message event saying why
        (for a robot the world does not have, at most once a second: a removed robot's agent may
        go on sending a while)."""
        why, reason = too_far_ahead(tick, self.core.tick), "tick"
        if keys.robot_id_of(key) != robot_id:
            why, reason = f"a message of robot {robot_id} on another robot's key", "key"
        elif robot_id not in self.core.registry.entries:
            reason = "unknown-robot"
            if now - self._unknown.get(robot_id, now - UNKNOWN_EVERY_NS) < UNKNOWN_EVERY_NS:
                return False
            if len(self._unknown) >= UNKNOWN_KEPT:
                self._unknown.clear()
            self._unknown[robot_id] = now
            why = f"robot {robot_id} is not in the world"
        if why:  # at most one report per key and reason a second, with its count
            self.io.refuse(reason, why, key=key, robot_id=robot_id, tick=self.core.tick)
        return not why

    def _take_actions(self, now: int) -> None:
        for d in self.actions.drain():
            a = self.io.decode(d, Actions)
            if a is not None and self._robot_message(d[0], a.robot_id, a.tick, now):
                self.io.send_all(self.core.on_actions(a, now))

    def _take_batches(self, now: int) -> None:
        core, io = self.core, self.io
        for d in self.batches.drain():
            b = io.decode(d, ActionBatch)
            if b is None:
                continue
            why = too_far_ahead(max([b.tick, *(a.tick for a in b.actions)]), core.tick)
            if keys.agent_of(d[0]) != b.agent:
                why = f"actions of agent {b.agent!r} on another agent's key"
            if why:
                io.refuse("batch", why, key=d[0], tick=core.tick)
                continue
            for a in b.actions:
                entry = core.registry.entries.get(a.robot_id)
                if entry is not None and entry.agent == b.agent:
                    io.send_all(core.on_actions(a, now))
                elif entry is not None:
                    why = f"agent {b.agent!r} sent actions for robot {a.robot_id}, not its own"
                    io.refuse("not-own", why, key=d[0], robot_id=a.robot_id, tick=core.tick)

    def wait_until(self, deadline_ns: int, done: object = None, needed: Callable[[], int] | None = None) -> None:
        """Pumps inputs until the deadline, or until ``done()`` is true.

        ``needed`` (lock-step, the actions inbox held): how many actions messages could still
        complete the wait; the actions inbox then wakes the loop once that many came since the
        last pump (:class:`~iw_zenoh.bus.wake.CountedWake`): one wake-up per tick, not one per robot.
        Every other inbox, and the poll, wake it as before."""
        counted = self.actions_wake
        while not self.io.stop.is_set():
            mark = counted.seen  # every delivery counted up to here is drained by this pump
            self.pump()
            if callable(done) and done():
                return
            left = (deadline_ns - self.clock.now_ns()) / 1e9
            if left <= 0:
                return
            if needed is not None:
                counted.wake_after(mark, needed())
            self.io.wait(min(left, 0.05))

    def take_verdict(self, deadline_ns: int) -> Verdict | None:
        """Waits for the verdict on the pending proposal, until the deadline, or until a
        collision process is lost: one restarted meanwhile never saw the proposal, so the tick
        is held at once rather than at the deadline (a minute in a patient lock-step run). Only
        liveliness is taken meanwhile (the roster stays the proposal's: ``sim/early.py``)."""
        lost = False
        while True:
            for d in self.verdicts.drain():
                v = self.io.decode(d, Verdict)
                if v is not None and self.core.verdict_ok(v):
                    return v
            lost |= self._take_alive(self.clock.now_ns())
            if lost or not self.core.collision_alive or self.io.stop.is_set():
                return None
            left = (deadline_ns - self.clock.now_ns()) / 1e9
            if left <= 0:
                return None
            self._answer_info()  # the collision process may need it to give this very verdict
            self.verdicts.wait(min(left, 0.01))

    def _await_actions(self, times: tuple[int, int, int] | None) -> None:
        """Lock-step: waits for every live agent's actions for the tick just committed, or the
        timeout (a laggard event names the late robots). ``times``: when the tick began, its verdict
        came and its state was published, to log (None: not logging)."""
        core, cfg = self.core, self.core.cfg
        n = core.tick
        self.actions_wake.hold()  # the loop held it before the proposal went out: holding again changes nothing
        try:
            self.wait_until(
                self.clock.now_ns() + int(cfg.lockstep_timeout_ms * MS),
                lambda: not core.waiting(n) or core.stopped or not core.due(),
                needed=lambda: core.waiting_for(n),
            )
        finally:
            self.actions_wake.release()
        late = core.expected(n)
        if times is not None:
            start, t_verdict, t_state = times
            logger.debug(
                "tick %d: propose+verdict %.2f ms, commit+publish %.2f ms, sensors+agents %.2f ms",
                n,
                (t_verdict - start) / 1e6,
                (t_state - t_verdict) / 1e6,
                (self.clock.now_ns() - t_state) / 1e6,
            )
        if late and core.due():
            self.io.event(
                EventKind.LAGGARD,
                f"tick {n}: no actions from robots {late} within {cfg.lockstep_timeout_ms:g} ms",
                LaggardData(robots=late),
                tick=n,
            )

    def loop(self) -> None:
        core, io, cfg = self.core, self.io, self.core.cfg
        period = cfg.period_ns
        next_ns = self.clock.now_ns()
        lockstep = cfg.mode == Mode.LOCKSTEP
        while not io.stop.is_set() and not core.stopped:
            self.pump()
            self._publish_info()
            if not core.due():
                io.send(keys.tick(cfg.sim), core.tick_msg())
                # the ciberrato profile waits out the cycle (its first step is the next one)
                self.wait_until(
                    self.clock.now_ns() + period,
                    lambda: core.stopped or core.due() and not core.starts_on_the_cycle,
                )
                next_ns = self.clock.now_ns()
                continue
            start = self.clock.now_ns()
            if lockstep:  # the tick's actions wake the loop once they may complete it (_await_actions)
                self.actions_wake.hold()
            io.send_all(core.begin_tick(start, self.clock.wall_ns()))
            # a legacy run (the ciberrato profile) waits for its verdict rather than hold the robots,
            # as the legacy simulator never does: its first step until collision has built its view
            # of the world, under load too; a later step is late, as the legacy's timer on a busy machine
            legacy = (FIRST_VERDICT_NS if core.tick == 0 else LEGACY_VERDICT_NS) if core.starts_on_the_cycle else 0
            verdict = self.take_verdict(start + max(cfg.verdict_wait_ns, legacy))
            t_verdict = self.clock.now_ns()
            io.send_all(core.finish_tick(verdict))
            t_state = self.clock.now_ns()
            debug = logger.isEnabledFor(logging.DEBUG)  # its figures are not worked out otherwise
            if debug:
                logger.debug(
                    "tick %d: started %.2f ms late, propose+verdict %.2f ms, commit+publish %.2f ms",
                    core.tick,
                    0.0 if lockstep else (start - next_ns) / 1e6,
                    (t_verdict - start) / 1e6,
                    (t_state - t_verdict) / 1e6,
                )
            if lockstep:
                self._await_actions((start, t_verdict, t_state) if debug else None)
            else:
                next_ns += period
                now = self.clock.now_ns()
                if next_ns < now - period:  # more than a tick behind: do not try to catch up
                    next_ns = now
                self.wait_until(next_ns)
        io.send(keys.tick(cfg.sim), core.tick_msg())


def run(bus: Bus, core: WorldCore, clock: Clock | None = None, *, name: str = "world") -> None:
    """Wires the world to a bus and runs its loop until it stops (duration, stop control, signal)."""
    _World(bus, core, clock or WallClock(), name).loop()


def world_config(opts: WorldOptions, sim: str) -> WorldConfig:
    """The world core's configuration from the options, in simulation ``sim``."""
    shared = {f: getattr(opts, f) for f in WorldSettings.__struct_fields__}  # declared once, copied by name
    return WorldConfig(
        **shared,
        sim=sim,
        expect=opts.expect,
        duration_ticks=int(round(opts.duration_s * 1000.0 / opts.period_ms)) if opts.duration_s > 0 else 0,
        owners=None if opts.owners is None else {a: None if r is None else tuple(r) for a, r in opts.owners.items()},
        reserved=None if opts.reserved is None else {a: tuple(r) for a, r in opts.reserved.items()},
    )


def prepare(args: argparse.Namespace) -> WorldCore:
    """The world's core from its options: the map and grid loaded, the obstacles placed.

    Raises:
        IwError: A refused option, a map that cannot be read.
        ValueError: An obstacle the world refuses.
    """
    opts = options_from_args(args, WorldOptions)
    if not opts.map:
        raise IwError("a map is required: iwz world MAP (or a map in --options)")
    lab = load_lab(opts.map)
    grid = load_grid(opts.grid, lab) if opts.grid else Grid(())
    core = WorldCore(world_config(opts, keys.chunk(args.sim)), lab, grid)
    for o in opts.resume.obstacles if opts.resume is not None else opts.obstacles:
        bad = [m for _, m in core.on_control(Control(command="add_obstacle", obstacle=o)) if isinstance(m, Event)]
        bad = [m for m in bad if m.kind == EventKind.BAD_CONTROL]
        if bad:
            raise ValueError(bad[0].reason)
    if opts.resume is not None:
        resume(core, opts.resume, time.monotonic_ns())
        logger.warning(
            "resuming at tick %d with %d robots (the world was restarted)", core.tick, len(core.registry.entries)
        )
    return core


def _run(proc: Process, core: WorldCore) -> None:
    w = _World(proc.bus, core, WallClock(), proc.name, io=proc.io)
    cfg, lab = core.cfg, core.obstacles.base_lab
    logger.info(
        "world %r on %s: %d walls, %d start positions, %s, %g ms",
        cfg.sim,
        lab.name,
        len(lab.walls),
        len(core.grid.positions),
        cfg.mode,
        cfg.period_ms,
    )
    try:
        w.loop()
    finally:
        time.sleep(0.05)  # let the last state and events leave before the session closes


def warm_up() -> None:
    """Compiles (or loads from the cache) the world's own kernels, its propose and commit
    (:mod:`iw_zenoh.core.drive`), before the process joins the bus."""
    drive.warm_up()


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz world``."""
    return start_role(
        argv,
        role="world",
        description=(
            "The world process: the clock, motors and kinematics, registration. "
            "Every other role talks to it over Zenoh."
        ),
        epilog=(
            "Examples:\n"
            "  iwz world maps/liacc.xml --grid maps/liacc-grid.xml --lockstep --seed 7\n"
            "  iwz world maps/liacc.xml --obstacle A:16.5,5.2,17,5.9 --duration 60\n"
            '  iwz world --options \'{"map": "maps/liacc.xml", "mode": "lockstep"}\'    (as iwz run starts it)'
        ),
        arguments=add_arguments,
        warm_up=warm_up,  # before joining: the first tick must not wait for a compilation
        prepare=prepare,
        run=_run,
    )
