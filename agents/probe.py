"""``iwz agent probe``: stands still (or creeps) and measures how late each reading arrives.

Its chair is the LIACC prototype with eight 60-degree cones of 4 m (the benchmarks' chair).

For benchmarks: with ``--latency-out FILE`` it writes, on exit, one line per reading: the delay
from the world's tick start to the reading's arrival here, in microseconds.
"""

from __future__ import annotations

import argparse
import atexit
import time
from pathlib import Path

from iw_zenoh.agent import Command
from iw_zenoh.core.spec import RobotSpec, prototype_sensors
from iw_zenoh.messages import Heard, SensorReading
from iw_zenoh.scenario.specfile import spec_with_args

CONES_4M = prototype_sensors(4.0)  # the core benchmark's chair

__all__ = ["Probe", "add_arguments", "make"]


class Probe:
    """A chair that records reading latencies.

    Args:
        name: Robot name.
        creep: Power on both wheels (0: stand still).
        sink: Where latencies (us) go (None: not kept; a long run would hold every one).
        spec: The robot (default: the benchmarks' chair).
        avoid_m: When a cone facing the way it creeps reads nearer than this, creep the other
            way (0: never; it then pushes into whatever it meets, colliding every tick).
    """

    def __init__(
        self, name: str, creep: float, sink: list[int] | None, spec: RobotSpec | None = None, avoid_m: float = 0.0
    ) -> None:
        self._spec = spec or RobotSpec(name, width_m=1.04, height_m=0.66, com=0.81, ir_sensors=CONES_4M)
        self.creep = creep
        self.sink = sink
        self.avoid_m = avoid_m
        self.direction = 1.0
        self._front = {s.id for s in self._spec.ir_sensors if abs(s.angle_deg) <= 60.0}
        self._rear = {s.id for s in self._spec.ir_sensors if abs(s.angle_deg) >= 120.0}

    def spec(self) -> RobotSpec:
        """The robot to register."""
        return self._spec

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """Records the delay since the tick began; creeps (back and forth, with ``avoid_m``) or stands."""
        if reading.tick_wall_ns and self.sink is not None:
            self.sink.append((time.time_ns() - reading.tick_wall_ns) // 1000)
        if self.avoid_m > 0.0:
            ahead = self._front if self.direction > 0 else self._rear
            near = [
                d
                for i, d in zip(reading.proximity_ids, reading.proximity_m, strict=False)
                if i in ahead and d is not None
            ]
            if near and min(near) < self.avoid_m:
                self.direction = -self.direction
        power = self.creep * self.direction
        return Command(power, power)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``iwz agent probe``."""
    p.add_argument("--count", type=int, default=1, help="robots to host (default 1)")
    p.add_argument("--robot-name", default="probe", help="robot name prefix")
    p.add_argument("--creep", type=float, default=0.0, help="power on both wheels (default 0)")
    p.add_argument(
        "--avoid",
        type=float,
        default=0.0,
        metavar="M",
        help="creep the other way when something is nearer than M metres ahead (default 0: push on)",
    )
    p.add_argument("--latency-out", help="write the reading delays (us) here on exit")


def make(args: argparse.Namespace) -> list[Probe]:
    """The agents the arguments ask for."""
    sink: list[int] | None = None  # kept only when asked: 250 chairs for 6,000 ticks held 42 MB
    if args.latency_out:
        out, kept = Path(args.latency_out), list[int]()
        sink = kept
        atexit.register(lambda: out.write_text("\n".join(map(str, kept)) + "\n"))
    probes = [Probe(f"{args.robot_name}{i + 1}"[:20], args.creep, sink, avoid_m=args.avoid) for i in range(args.count)]
    if not getattr(args, "spec_table", None):
        return probes
    return [Probe(p.spec().name, p.creep, sink, spec_with_args(p.spec(), args), p.avoid_m) for p in probes]
