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

CONES_4M = prototype_sensors(4.0)  # the core benchmark's chair

__all__ = ["Probe", "add_arguments", "make"]


class Probe:
    """A chair that records reading latencies.

    Args:
        name: Robot name.
        creep: Power on both wheels (0: stand still).
        sink: Where latencies (us) go.
    """

    def __init__(self, name: str, creep: float, sink: list[int], spec: RobotSpec | None = None) -> None:
        self._spec = spec or RobotSpec(name, width_m=1.04, height_m=0.66, com=0.81, ir_sensors=CONES_4M)
        self.creep = creep
        self.sink = sink

    def spec(self) -> RobotSpec:
        """The robot to register."""
        return self._spec

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """Records the delay since the tick began; creeps or stands."""
        if reading.tick_wall_ns:
            self.sink.append((time.time_ns() - reading.tick_wall_ns) // 1000)
        return Command(self.creep, self.creep)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``iwz agent probe``."""
    p.add_argument("--count", type=int, default=1, help="robots to host (default 1)")
    p.add_argument("--robot-name", default="probe", help="robot name prefix")
    p.add_argument("--creep", type=float, default=0.0, help="power on both wheels (default 0)")
    p.add_argument("--latency-out", help="write the reading delays (us) here on exit")


def make(args: argparse.Namespace) -> list[Probe]:
    """The agents the arguments ask for."""
    sink: list[int] = []
    if args.latency_out:
        out = Path(args.latency_out)
        atexit.register(lambda: out.write_text("\n".join(map(str, sink)) + "\n"))
    return [Probe(f"{args.robot_name}{i + 1}"[:20], args.creep, sink) for i in range(args.count)]
