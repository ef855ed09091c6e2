"""``iwz agent manual``: a chair a person drives, from the page (``iwz view``: drive), a gamepad
or a recorded input trace (``--input-trace``), with shared control (docs/driving.md).

The driver's input comes on ``robot/{id}/drive`` (``DriveInput``); the chair publishes what it
does with it on ``robot/{id}/driving`` (``DriveState``) every tick. The stick is proportional:
a dead zone, speed levels (1..5: level k allows k/5 of the chair's top speed), the chair's own
top speed and a comfort acceleration; the agent turns (v, w) into wheel powers through the
chair's motor model. Shared control (``--assist``): ``off`` drives the input as given, ``safe``
never drives into what the chair's sensors see, ``assist`` also steers round obstacles and
through doorways (``iw_zenoh/core/assist.py``). Go there (``goto`` in the input): the chair's
planner (the wheelchair's autopilot, on ``--map``) takes it there while the driver's input keeps
coming. One driver at a time; no input for 300 ms and the chair stops (``agents/seat.py``).

A live driver's input that changes the stick is answered at once, between ticks
(:meth:`ManualChair.drive_now`: the host sends the tick's command again, made from the same
readings with the new input), not at the next tick: a key's latency is then the network's, not
up to a tick's. The answer again goes through the same ramp, shared control and dead-man, and is
kept within one tick's comfort acceleration of every command sent this tick and the tick before
(the world applies whichever came last before its step). Replayed traces and lock-step runs
answer only on ticks, so they replay exactly.

Examples::

    iwz agent manual --id 1 --start 3,5,0 --assist safe --map maps/open-room.xml
    iwz agent manual --id 1 --start 10,6.1,0 --input-trace maps/scenarios/slalom-manual.trace.jsonl
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import msgspec

from iw_zenoh.agent import Command
from iw_zenoh.agent.places import pose_arg
from iw_zenoh.core.assist import DriveLimits, SharedControl, ramp, seen_points, stick_twist
from iw_zenoh.core.lab import Lab
from iw_zenoh.core.motor import powers_for_twist
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.errors import DecodeError
from iw_zenoh.maps import load_lab
from iw_zenoh.messages import ASSIST_LEVELS, DriveInput, DriveState, Heard, SensorReading, decode
from iw_zenoh.scenario.specfile import spec_with_args

from .autopilot import Autopilot, mapping_chair
from .seat import DriverSeat

__all__ = ["ManualChair", "add_arguments", "load_trace", "make"]

TRACE_MAX = 1_000_000  # inputs in a trace file (a 20 Hz hour is 72,000)
DT_S = 0.1  # the tick assumed before two readings tell it


@dataclass(frozen=True)
class _Tick:
    """What a tick's answer was made from, so that a new input answers the tick again: its
    readings, its dt, the command and motor model before it, and the stick it used."""

    reading: SensorReading
    dt_s: float
    cmd: tuple[float, float]
    motor: tuple[float, float]


def load_trace(path: str | Path) -> list[DriveInput]:
    """A recorded input trace: one ``DriveInput`` JSON a line (``sim_time_ns`` says when it is
    given; blank lines and lines starting with ``#`` are skipped), in time order.

    Raises:
        ValueError: Naming the file, the line and what is wrong.
    """
    out: list[DriveInput] = []
    try:
        lines = Path(path).read_bytes().splitlines()
    except OSError as e:
        raise ValueError(f"--input-trace {path}: {e.strerror or e}") from None
    for n, line in enumerate(lines, 1):
        if not line.strip() or line.lstrip().startswith(b"#"):
            continue
        try:
            msg = decode(line, DriveInput)
        except DecodeError as e:
            raise ValueError(f"--input-trace {path} line {n}: {e}") from None
        if out and msg.sim_time_ns < out[-1].sim_time_ns:
            raise ValueError(f"--input-trace {path} line {n}: sim_time_ns goes back in time")
        out.append(msg)
        if len(out) > TRACE_MAX:
            raise ValueError(f"--input-trace {path}: more than {TRACE_MAX} inputs")
    return out


class ManualChair:
    """A chair its driver drives (see the module doc).

    Args:
        spec: The chair.
        known: The map its planner plans on for go there (None: go there is refused).
        assist: Shared control until a driver changes it.
        level: Speed level until a driver says.
        trace: Inputs to replay as the driver, at their simulation times.
        clock: Seconds, for the dead-man of a live driver (a trace uses simulation time).
    """

    def __init__(
        self,
        spec: RobotSpec,
        known: Lab | None = None,
        *,
        assist: str = "off",
        level: int = 1,
        trace: list[DriveInput] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._spec = spec
        self.known = known
        self.lim = DriveLimits.of(spec)
        self.shared = SharedControl(spec, self.lim)
        self.seat = DriverSeat(spec.id, level=level, assist=assist)
        self.trace = list(trace or [])
        self._next = 0
        self.clock = clock
        self.cmd = (0.0, 0.0)
        self.pilot: Autopilot | None = None
        self._goal: tuple[float, float] | None = None
        self._t_ns: int | None = None
        self.state: DriveState | None = None
        self._replayed: list[DriveInput] = []
        self.robot_id = spec.id
        self._tick: _Tick | None = None
        self._used: tuple[float, float, int] | None = None  # the stick (x, y, level) the last answer used
        self._sent: list[tuple[float, float]] = []  # the commands sent this tick (its answer, then again)
        self._sent_before: list[tuple[float, float]] = []  # and the tick before

    def spec(self) -> RobotSpec:
        """The chair to register."""
        return self._spec

    def on_registered(self, robot_id: int, spec: RobotSpec) -> None:
        """Learns its id: drivers' inputs name it."""
        self.robot_id = self.seat.robot_id = robot_id
        self._spec = spec

    def on_drive(self, msg: DriveInput) -> None:
        """A live driver's input (a trace replays its own)."""
        if not self.trace:
            self.seat.offer(msg, self.clock())

    def drive_messages(self) -> list[DriveInput | DriveState]:
        """This tick's drive messages for the host to publish: the inputs a trace replayed (on
        ``drive``, as a live driver's), then what the chair did with them (on ``driving``)."""
        out: list[DriveInput | DriveState] = [*self._replayed]
        self._replayed.clear()
        if self.state is not None:
            out.append(self.state)
        return out

    def _replay(self, t_ns: int) -> None:
        while self._next < len(self.trace) and self.trace[self._next].sim_time_ns <= t_ns:
            m = self.trace[self._next]
            if m.robot_id != self.robot_id:  # a trace recorded with another chair
                m = msgspec.structs.replace(m, robot_id=self.robot_id)
            self.seat.offer(m, m.sim_time_ns / 1e9)
            self._replayed.append(m)
            self._next += 1

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """This tick: the driver's stick (or the planner's go there) through shared control."""
        t_ns = reading.sim_time_ns
        dt = DT_S if self._t_ns is None or t_ns <= self._t_ns else (t_ns - self._t_ns) / 1e9
        self._t_ns = t_ns
        if self.trace:
            self._replay(t_ns)
            now = t_ns / 1e9
        else:
            now = self.clock()
        self._tick = _Tick(reading, dt, self.cmd, self.shared.motor)
        self._sent_before, self._sent = self._sent, []
        return self._answer(self._tick, now)

    def drive_now(self) -> Command | None:
        """The tick's command again, at once, when a live driver's newest input changed the stick
        its answer used (None: unchanged, a trace, a go-there goal, or no tick yet). Made from the
        tick's own readings and the command before it, so the tick is answered as if the input
        had come before it; the host sends it on the tick's actions key (real time only)."""
        t = self._tick
        if t is None or self.trace or self.seat.goal is not None:
            return None
        stick = self.seat.stick(self.clock())
        if (stick.x, stick.y, self.seat.level) == self._used or stick.stale:
            return None
        self.cmd, self.shared.motor = t.cmd, t.motor
        return self._answer(t, self.clock())

    def _answer(self, t: _Tick, now: float) -> Command:
        """The tick's command for the stick (or goal) at ``now``, and its drive state."""
        reading = t.reading
        stick = self.seat.stick(now)
        self._used = (stick.x, stick.y, self.seat.level)
        seen = [d for d in reading.proximity_m if d is not None]
        nearest = min(seen) if seen else None
        points = seen_points(self._spec, list(reading.proximity_ids), list(reading.proximity_m))
        goal = self._goal_drive(reading) if not stick.stale else None
        if stick.stale:
            want = (0.0, 0.0)
            self.cmd = want
        elif goal is not None:
            want = goal
        else:
            want = ramp(self.cmd, stick_twist(stick.x, stick.y, self.seat.level, self.lim), t.dt_s, self.lim)
            for sent in (*self._sent_before, *self._sent):  # whichever of them the world applied last
                want = ramp(sent, want, t.dt_s, self.lim)
        out = self.shared.step(self.seat.assist, want, points, t.dt_s, nearest)
        self.cmd = (out.v_mps, out.w_radps)
        self._sent.append(self.cmd)
        left, right = powers_for_twist(out.v_mps, out.w_radps, self._spec.max_speed_mps, self._spec.height_m)
        self.state = self._drive_state(reading, out.v_mps, out.w_radps, want, out.intervened, nearest, stick.stale)
        return Command(left, right)

    def _drive_state(
        self,
        reading: SensorReading,
        v: float,
        w: float,
        want: tuple[float, float],
        intervened: bool,
        nearest: float | None,
        stale: bool,
    ) -> DriveState:
        last = self.seat.last
        return DriveState(
            tick=reading.tick,
            sim_time_ns=reading.sim_time_ns,
            robot_id=self.robot_id,
            driver=self.seat.driver,
            seq=last.seq if last is not None else 0,
            level=self.seat.level,
            assist=self.seat.assist,  # type: ignore[arg-type]
            v_mps=v,
            w_radps=w,
            input_v_mps=want[0],
            input_w_radps=want[1],
            intervened=intervened,
            nearest_m=nearest,
            goal=self.seat.goal,
            stale=stale,
            refused=self.seat.refused,
        )

    def _goal_drive(self, reading: SensorReading) -> tuple[float, float] | None:
        """The planner's (v, w) towards the seat's goal, or None (no goal, arrived, no map)."""
        goal = self.seat.goal
        if goal is None or self.known is None:
            self.seat.goal = None
            return None
        if self.pilot is None:
            self.pilot = Autopilot(self._spec, self.known)
        if goal != self._goal:
            self.pilot.set_goal(goal)
            self._goal = goal
        if self.pilot.arrived(reading.gps):
            self.seat.goal = self._goal = None
            return 0.0, 0.0
        d = self.pilot.step(reading.gps, list(reading.proximity_ids), list(reading.proximity_m))
        return 0.5 * (d.left_mps + d.right_mps), (d.right_mps - d.left_mps) / self._spec.height_m


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``iwz agent manual``."""
    p.add_argument("--start", type=pose_arg, help="start pose x,y,dir_deg (default: the grid position of its id)")
    p.add_argument("--map", help="the map its planner knows, for go there (Lab XML; without it go there is refused)")
    p.add_argument(
        "--assist", choices=ASSIST_LEVELS, default="off", help="shared control until the driver changes it (off)"
    )
    p.add_argument("--level", type=int, choices=range(1, 6), default=1, help="speed level 1..5 until the driver says")
    p.add_argument(
        "--input-trace",
        metavar="FILE",
        help="replay this input trace as the driver (one DriveInput JSON a line, at its sim_time_ns)",
    )
    p.add_argument("--id", type=int, default=0, help="robot id to ask for (default: first free grid slot)")
    p.add_argument("--robot-name", default="manual", help="robot name (default manual)")


def make(args: argparse.Namespace) -> list[ManualChair]:
    """The chair the arguments ask for."""
    kw: dict[str, object] = {"id": args.id}
    if args.start is not None:
        x, y, d = args.start
        kw.update(x_m=x, y_m=y, dir_deg=d)
    spec = spec_with_args(mapping_chair(args.robot_name, **kw), args)
    trace = load_trace(args.input_trace) if args.input_trace else None
    known = load_lab(args.map) if args.map else None
    return [ManualChair(spec, known, assist=args.assist, level=args.level, trace=trace)]
