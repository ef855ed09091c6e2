"""``iwz agent wanderer``: drives about, turning away from whatever its proximity sensors see.

A seeded random walk: cruise forward, and when something is nearer than the safety distance in
front, turn towards the side with more room for a while.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from iw_zenoh.agent import Command
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import Heard, SensorReading
from iw_zenoh.scenario.specfile import spec_with_args

__all__ = ["Wanderer", "add_arguments", "make"]

CRUISE = 0.08  # power: a bit over half of MaxSpeed
TURN = 0.06


class Wanderer:
    """A random walker that keeps off walls and other chairs.

    Args:
        name: Robot name.
        rng: Its own seeded generator.
        safety_m: Turn away when something is this near in front.
    """

    def __init__(
        self, name: str, rng: np.random.Generator, *, safety_m: float = 0.8, spec: RobotSpec | None = None
    ) -> None:
        self._spec = spec or RobotSpec(name, width_m=1.04, height_m=0.66, com=0.81, acceleration_curve=0.5)
        self.rng = rng
        self.safety_m = safety_m
        self.turning = 0
        self.direction = 1.0

    def spec(self) -> RobotSpec:
        """The robot to register."""
        return self._spec

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """Cruise, or turn away from what is in front."""
        angles = {s.id: s.angle_deg for s in self._spec.sensors}
        front = [
            d
            for i, d in zip(reading.proximity_ids, reading.proximity_m, strict=True)
            if d is not None and abs(angles.get(i, 0.0)) < 50
        ]
        left = [
            d
            for i, d in zip(reading.proximity_ids, reading.proximity_m, strict=True)
            if d is not None and 50 <= angles.get(i, 0.0) <= 130
        ]
        right = [
            d
            for i, d in zip(reading.proximity_ids, reading.proximity_m, strict=True)
            if d is not None and -130 <= angles.get(i, 0.0) <= -50
        ]
        if self.turning > 0:
            self.turning -= 1
            return Command(-TURN * self.direction, TURN * self.direction)
        if (front and min(front) < self.safety_m) or reading.collision:
            room_left = min(left, default=math.inf)
            room_right = min(right, default=math.inf)
            self.direction = 1.0 if room_left >= room_right else -1.0
            self.turning = int(self.rng.integers(3, 12))
            return Command(-TURN * self.direction, TURN * self.direction)
        wobble = float(self.rng.normal(0.0, 0.01))
        return Command(CRUISE - wobble, CRUISE + wobble)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``iwz agent wanderer``."""
    p.add_argument("--count", type=int, default=1, help="robots to host in this process (default 1)")
    p.add_argument("--robot-name", default="wanderer", help="robot name prefix (default wanderer)")
    p.add_argument("--seed", type=int, default=0, help="seed of the walks (default 0)")
    p.add_argument(
        "--safety", type=float, default=0.8, help="turn away when something is this near in front, m (default 0.8)"
    )


def make(args: argparse.Namespace) -> list[Wanderer]:
    """The agents the arguments ask for."""
    seeds = np.random.SeedSequence(args.seed).spawn(args.count)
    walkers = [
        Wanderer(f"{args.robot_name}{i + 1}"[:20], np.random.default_rng(s), safety_m=args.safety)
        for i, s in enumerate(seeds)
    ]
    if not getattr(args, "spec_table", None):
        return walkers
    return [Wanderer(w.spec().name, w.rng, safety_m=w.safety_m, spec=spec_with_args(w.spec(), args)) for w in walkers]
