"""A chair emulated in-process on the simulation core: the stand-in for real hardware.

:class:`LocalWorld` steps robots on a lab with the core's motors, collision and sensors, with
no Zenoh and no clock. Two uses:

* the *emulated real chair* of the augmented mode: its own "true" world (the real room), its own
  noisy sonars, and an odometry pose integrated from its wheel encoders (which slip, so the pose
  it reports drifts from the truth, as a real chair's does);
* fast, deterministic runs of an agent's logic in tests, with readings shaped exactly as the
  sensors process sends them.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.collision import check_collisions
from iw_zenoh.core.lab import Lab, Scene
from iw_zenoh.core.noise import Stream, rng_for
from iw_zenoh.core.odometry import WheelOdometry
from iw_zenoh.core.sensors import noise_layout, read_sensors
from iw_zenoh.core.spec import NoiseSpec, RobotSpec, RobotType
from iw_zenoh.core.world import WorldState, commit, initial_state, propose
from iw_zenoh.messages import SensorReading

__all__ = ["EmulatedChair", "LocalWorld"]

logger = logging.getLogger(__name__)

EMULATED_SLIP = NoiseSpec(0.0, 0.005)  # a decent encoder: 0.5 % slip per tick, odometry drifts slowly


class LocalWorld:
    """Robots stepped in-process on the core (native profile).

    Args:
        lab: The room (walls and obstacles).
        specs: The robots, each with its id and start pose set.
        seed: Seeds every robot's sensor stream.
        dt_s: Tick length.
    """

    def __init__(self, lab: Lab, specs: Sequence[RobotSpec], *, seed: int = 0, dt_s: float = 0.1) -> None:
        self.scene = Scene(lab)
        self.specs = list(specs)
        self.ids = [s.id for s in self.specs]
        self.bodies = Bodies.from_specs(self.specs)
        self.dt_s = dt_s
        pose = np.array([[s.x_m or 0.0, s.y_m or 0.0, math.radians(s.dir_deg or 0.0)] for s in self.specs])
        self.state: WorldState = initial_state(pose)
        self.collisions = 0
        self._rngs = [rng_for(seed, i, Stream.SENSORS) for i in self.ids]
        self._counts, self._starts = noise_layout(self.bodies, len(lab.beacons))
        self._enc = np.zeros((len(self.specs), 2))

    def pose(self, robot_id: int) -> tuple[float, float, float]:
        """The true pose (x, y, heading deg)."""
        x, y, th = self.state.pose[self.ids.index(robot_id)]
        return float(x), float(y), math.degrees(float(th))

    def step(self, commands: dict[int, tuple[float, float]]) -> dict[int, SensorReading]:
        """Applies the commands (robots not named keep theirs) for one tick; returns readings."""
        cmd = self.state.cmd.copy()
        for rid, (left, right) in commands.items():
            cmd[self.ids.index(rid)] = (left, right)
        st = WorldState(
            self.state.tick, self.state.pose, self.state.motor_out, cmd, self.state.collided, self.state.rolled_m
        )
        prop = propose(st, self.bodies, dt_s=self.dt_s)
        col = check_collisions(self.scene, self.bodies.outline, st.pose, prop.pose)
        self.state = commit(st, prop, col)
        self.collisions += int(np.count_nonzero(col.collided))
        z = np.concatenate([g.standard_normal(int(c)) for g, c in zip(self._rngs, self._counts, strict=True)])
        r = read_sensors(
            self.scene,
            self.bodies,
            self.state.pose,
            collided=self.state.collided,
            encoder_acc=self._enc,
            rolled_m=self.state.rolled_m,
            z=z,
        )
        self._enc = r.encoder_acc
        out: dict[int, SensorReading] = {}
        owner = self.bodies.ir_owner
        for i, rid in enumerate(self.ids):
            sel = owner == i
            prox = [None if not math.isfinite(v) else float(v) for v in r.proximity_m[sel].tolist()]
            out[rid] = SensorReading(
                tick=self.state.tick,
                sim_time_ns=int(round(self.state.tick * self.dt_s * 1e9)),
                robot_id=rid,
                proximity_ids=self.bodies.ir_id[sel].tolist(),
                proximity_m=prox,
                proximity_legacy=r.proximity_legacy[sel].tolist(),
                compass_deg=float(r.compass_deg[i]),
                gps=(float(r.gps[i, 0]), float(r.gps[i, 1]), float(r.gps[i, 2])),
                collision=bool(r.collision[i]),
                encoders=(int(r.encoder_ticks[i, 0]), int(r.encoder_ticks[i, 1])),
            )
        return out


class EmulatedChair:
    """A real chair, emulated: true motion and own sensors in its room, odometry from encoders.

    Args:
        spec: The chair (its start pose set).
        room: The real room (walls and real obstacles).
        seed: Noise seed.
    """

    def __init__(self, spec: RobotSpec, room: Lab, seed: int = 0) -> None:
        noise = replace(spec.noise, encoder_slip=EMULATED_SLIP)
        self.spec = replace(spec, id=1, type=RobotType.SIMULATED, noise=noise)
        self.world = LocalWorld(room, [self.spec], seed=seed)
        self.odometry = WheelOdometry(
            (spec.x_m or 0.0, spec.y_m or 0.0, spec.dir_deg or 0.0),
            spec.height_m,
            spec.encoder.ticks_per_m,
            counts=(0, 0),  # the emulated encoders count from zero at the start pose
        )
        self.pose = (spec.x_m or 0.0, spec.y_m or 0.0, spec.dir_deg or 0.0)
        self.reading = self.world.step({})[1]
        self.real_collisions = 0

    def drive(self, left: float, right: float) -> None:
        """One tick of the hardware at these powers."""
        self.reading = self.world.step({1: (left, right)})[1]
        self.pose = self.odometry.update(self.reading.encoders)
        if self.reading.collision:
            self.real_collisions += 1
            logger.warning("the real chair touched something at %s (true pose)", self.world.pose(1))
