"""``iwz world MAP``: the world process (see :mod:`iw_zenoh.sim.world` for the logic).

Wiring: registration and info queryables, actions / pose reports / control / verdict inboxes,
liveliness of collision processes and agents; then the tick loop in real time or lock-step.
"""

from __future__ import annotations

import argparse
import logging
import time
from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.bus import Bus, ZenohBus
from iw_zenoh.cliargs import add_common_arguments, net_from_args
from iw_zenoh.clock import Clock, WallClock
from iw_zenoh.core.lab import Grid
from iw_zenoh.core.modes import Mode, Profile
from iw_zenoh.errors import IwError
from iw_zenoh.maps import load_grid, load_lab
from iw_zenoh.messages import (
    ActionBatch,
    Actions,
    Control,
    EventKind,
    LaggardData,
    Obstacle,
    PoseReport,
    RefusedData,
    RegisterReply,
    RegisterRequest,
    Verdict,
    decode,
    encode,
)
from iw_zenoh.nodes.base import NodeIO, install_stop_signals, setup_logging
from iw_zenoh.sim.config import MS, WorldConfig
from iw_zenoh.sim.world import WorldCore

__all__ = ["main", "run"]

logger = logging.getLogger(__name__)


class _World:
    """The world's I/O loop around a :class:`WorldCore`."""

    def __init__(self, bus: Bus, core: WorldCore, clock: Clock, name: str) -> None:
        self.core = core
        self.clock = clock
        sim = core.cfg.sim
        self.io = NodeIO(bus, sim, "world", name)
        self.actions = self.io.inbox(keys.all_actions(sim))
        self.batches = self.io.inbox(keys.all_agent_actions(sim))
        self.reports = self.io.inbox(keys.all_pose_reports(sim))
        self.control = self.io.inbox(keys.control(sim))
        self.verdicts = self.io.inbox(keys.verdict(sim))
        self.register_q = bus.serve(keys.register(sim))
        self.info_q = bus.serve(keys.info(sim))
        self.alive_changes: list[tuple[str, bool]] = []
        self._info_revision = -1
        bus.watch_alive(keys.all_alive(sim), self._on_alive)
        self.io.alive()

    def _answer_info(self) -> None:
        """Answers late joiners' info queries (also while a tick waits for its verdict)."""
        pending = self.info_q.poll()
        if pending:
            data = encode(self.core.info())
            for q in pending:
                q.reply(data)

    def _publish_info(self) -> None:
        """Publishes the world's description whenever it changed (recorders, replays, viewers)."""
        if self.core.revision != self._info_revision:
            self._info_revision = self.core.revision
            self.io.send(keys.info(self.core.cfg.sim), self.core.info())

    def _on_alive(self, key: str, alive: bool) -> None:
        self.alive_changes.append((key, alive))  # list.append is atomic; drained by the loop
        self.io.wake.set()

    def pump(self) -> None:
        """Handles every input waiting now (not verdicts: the tick takes those)."""
        now = self.clock.now_ns()
        core, io = self.core, self.io
        while self.alive_changes:
            key, alive = self.alive_changes.pop(0)
            parts = keys.alive_parts(key)
            if parts:
                io.send_all(core.on_alive(parts[0], parts[1], alive, now))
        for q in self.register_q.poll():
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
            reply, out = core.register(req, now)
            q.reply(encode(reply))
            io.send_all(out)
        self._answer_info()
        for d in self.control.drain():
            msg = io.decode(d, Control)
            if msg is not None:
                io.send_all(core.on_control(msg))
        for d in self.actions.drain():
            a = io.decode(d, Actions)
            if a is not None and keys.robot_id_of(d[0]) == a.robot_id:
                io.send_all(core.on_actions(a, now))
            elif a is not None:
                io.event(EventKind.BAD_MESSAGE, f"actions for robot {a.robot_id} on another robot's key", key=d[0])
        for d in self.batches.drain():
            b = io.decode(d, ActionBatch)
            if b is None:
                continue
            if keys.agent_of(d[0]) != b.agent:
                io.event(EventKind.BAD_MESSAGE, f"actions of agent {b.agent!r} on another agent's key", key=d[0])
                continue
            for a in b.actions:
                entry = core.registry.entries.get(a.robot_id)
                if entry is not None and entry.agent == b.agent:
                    io.send_all(core.on_actions(a, now))
                elif entry is not None:
                    io.event(
                        EventKind.BAD_MESSAGE,
                        f"agent {b.agent!r} sent actions for robot {a.robot_id}, not its own",
                        key=d[0],
                    )
        for d in self.reports.drain():
            r = io.decode(d, PoseReport)
            if r is not None and keys.robot_id_of(d[0]) == r.robot_id:
                core.on_pose_report(r, now)

    def wait_until(self, deadline_ns: int, done: object = None) -> None:
        """Pumps inputs until the deadline, or until ``done()`` is true."""
        while not self.io.stop.is_set():
            self.pump()
            if callable(done) and done():
                return
            left = (deadline_ns - self.clock.now_ns()) / 1e9
            if left <= 0:
                return
            self.io.wait(min(left, 0.05))

    def take_verdict(self, deadline_ns: int) -> Verdict | None:
        """Waits for the verdict on the pending proposal, until the deadline."""
        while True:
            for d in self.verdicts.drain():
                v = self.io.decode(d, Verdict)
                if v is not None and self.core.verdict_ok(v):
                    return v
            if not self.core.collision_alive or self.io.stop.is_set():
                return None
            left = (deadline_ns - self.clock.now_ns()) / 1e9
            if left <= 0:
                return None
            self._answer_info()  # the collision process may need it to give this very verdict
            self.verdicts.wait(min(left, 0.01))

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
                self.wait_until(self.clock.now_ns() + period, lambda: core.due() or core.stopped)
                next_ns = self.clock.now_ns()
                continue
            start = self.clock.now_ns()
            io.send_all(core.begin_tick(start, self.clock.wall_ns()))
            verdict_wait = int(cfg.verdict_timeout_ms * MS) if lockstep else period // 2
            verdict = self.take_verdict(start + verdict_wait)
            t_verdict = self.clock.now_ns()
            io.send_all(core.finish_tick(verdict))
            t_state = self.clock.now_ns()
            logger.debug(
                "tick %d: started %.2f ms late, propose+verdict %.2f ms, commit+publish %.2f ms",
                core.tick,
                0.0 if lockstep else (start - next_ns) / 1e6,
                (t_verdict - start) / 1e6,
                (t_state - t_verdict) / 1e6,
            )
            if lockstep:
                n = core.tick
                self.wait_until(
                    self.clock.now_ns() + int(cfg.lockstep_timeout_ms * MS),
                    lambda n=n: not core.waiting(n) or core.stopped or not core.due(),
                )
                late = core.expected(n)
                t_acts = self.clock.now_ns()
                logger.debug(
                    "tick %d: propose+verdict %.2f ms, commit+publish %.2f ms, sensors+agents %.2f ms",
                    n,
                    (t_verdict - start) / 1e6,
                    (t_state - t_verdict) / 1e6,
                    (t_acts - t_state) / 1e6,
                )
                if late and core.due():
                    io.event(
                        EventKind.LAGGARD,
                        f"tick {n}: no actions from robots {late} within {cfg.lockstep_timeout_ms:g} ms",
                        LaggardData(robots=late),
                        tick=n,
                    )
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


def build_parser() -> argparse.ArgumentParser:
    """The arguments of ``iwz world``."""
    p = argparse.ArgumentParser(
        prog="iwz world",
        description=(
            "The world process: the clock, motors and kinematics, registration. "
            "Every other role talks to it over Zenoh."
        ),
        epilog="Example: iwz world maps/liacc.xml --grid maps/liacc-grid.xml --lockstep --seed 7",
    )
    p.add_argument("map", help="Lab XML file (Ciber-Rato / Intellwheels)")
    p.add_argument("--grid", help="Grid XML file of start positions (default: none; robots then give X and Y)")
    p.add_argument("--period-ms", type=float, default=100.0, help="tick period in ms (default 100; Ciber-Rato uses 50)")
    p.add_argument(
        "--lockstep",
        action="store_true",
        help="lock-step: wait for every live agent's actions each tick (default: real time)",
    )
    p.add_argument(
        "--profile",
        choices=[p.value for p in Profile],
        default=Profile.NATIVE.value,
        help="motion and collision rules (default native)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of movement noise (default 0)")
    p.add_argument(
        "--action-timeout-ms",
        type=float,
        default=500.0,
        help="zero a robot's motors when its actions are older (default 500)",
    )
    p.add_argument(
        "--grace-ms", type=float, default=5000.0, help="remove a robot this long after its agent is gone (default 5000)"
    )
    p.add_argument(
        "--lockstep-timeout-ms",
        type=float,
        default=2000.0,
        help="lock-step: wait this long for a tick's actions (default 2000)",
    )
    p.add_argument("--expect", type=int, default=0, help="wait for this many robots before the first tick (default 0)")
    p.add_argument(
        "--duration",
        type=float,
        default=0.0,
        help="stop after this many simulated seconds (default: run until stopped)",
    )
    p.add_argument("--paused", action="store_true", help="start paused; a 'start' control runs it")
    p.add_argument("--motors-noise", type=float, default=0.0, help="Ciber-Rato MotorsNoise, percent (legacy profile)")
    p.add_argument(
        "--obstacle",
        action="append",
        default=[],
        metavar="NAME:X0,Y0,X1,Y1[,H]",
        help="a rectangular obstacle from the start (repeatable)",
    )
    p.add_argument("--name", default="world", help="instance name (liveliness)")
    add_common_arguments(p)
    return p


def parse_obstacle(text: str) -> Obstacle:
    """Parses ``NAME:X0,Y0,X1,Y1[,H]``.

    Raises:
        ValueError: Saying what the form is.
    """
    name, sep, rest = text.partition(":")
    try:
        v = [float(x) for x in rest.split(",")]
    except ValueError:
        v = []
    if not sep or not name or len(v) not in (4, 5):
        raise ValueError(f"--obstacle takes NAME:X0,Y0,X1,Y1[,HEIGHT], got {text!r}")
    return Obstacle(name=name, x0=v[0], y0=v[1], x1=v[2], y1=v[3], height=v[4] if len(v) == 5 else 1.0)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz world``."""
    args = build_parser().parse_args(argv)
    setup_logging(args.verbose, "world")
    try:
        lab = load_lab(args.map)
        grid = load_grid(args.grid, lab) if args.grid else Grid(())
        cfg = WorldConfig(
            sim=keys.chunk(args.sim),
            period_ms=args.period_ms,
            mode=Mode.LOCKSTEP if args.lockstep else Mode.REALTIME,
            profile=Profile(args.profile),
            seed=args.seed,
            action_timeout_ms=args.action_timeout_ms,
            grace_ms=args.grace_ms,
            lockstep_timeout_ms=args.lockstep_timeout_ms,
            expect=args.expect,
            duration_ticks=int(round(args.duration * 1000.0 / args.period_ms)) if args.duration > 0 else 0,
            start_paused=args.paused,
            motors_noise_pct=args.motors_noise,
        )
        if args.period_ms <= 0:
            raise IwError(f"--period-ms must be > 0, got {args.period_ms:g}")
        bus = ZenohBus(net_from_args(args))
    except (IwError, ValueError) as e:
        print(f"iwz world: {e}")
        return 2
    core = WorldCore(cfg, lab, grid)
    try:
        for text in args.obstacle:
            bad = [
                m
                for _, m in core.on_control(Control(command="add_obstacle", obstacle=parse_obstacle(text)))
                if getattr(m, "kind", "") == EventKind.BAD_CONTROL
            ]
            if bad:
                raise ValueError(bad[0].reason)  # type: ignore[attr-defined]
    except ValueError as e:
        print(f"iwz world: {e}")
        bus.close()
        return 2
    w = _World(bus, core, WallClock(), args.name)
    install_stop_signals(w.io.stop, w.io.wake.set)
    logger.info(
        "world %r on %s: %d walls, %d start positions, %s, %g ms",
        cfg.sim,
        lab.name,
        len(lab.walls),
        len(grid.positions),
        cfg.mode,
        cfg.period_ms,
    )
    try:
        w.loop()
    finally:
        time.sleep(0.05)  # let the last state and events leave before the session closes
        bus.close()
    return 0
