"""The world's tick as pure functions: propose next poses, then commit them after the collision
verdict. The world node calls :func:`propose` and :func:`commit` on either side of the
collision process; :func:`step` chains the three for tests, benchmarks and lock-step re-runs.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.collision import Collisions, check_collisions, check_collisions_ciberrato
from iw_zenoh.core.lab import Scene
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.motor import clamp_power, step_drive, step_drive_ciberrato, wheel_speeds_mps
from iw_zenoh.core.spec import RobotType

__all__ = [
    "Profile",  # re-exported: its home is core.modes
    "Proposal",
    "WorldState",
    "commit",
    "initial_state",
    "propose",
    "step",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class WorldState:
    """Everything that changes from tick to tick, for N robots in :class:`Bodies` order.

    Attributes:
        tick: Ticks stepped so far.
        pose: (N, 3) x (m), y (m), heading (rad).
        motor_out: (N, 2) motor outputs (power units), left and right.
        cmd: (N, 2) the last commanded powers (sticky).
        collided: (N,) the last tick's collision flags.
        rolled_m: (N, 2) how far each wheel rolled in the last tick.
    """

    tick: int
    pose: FloatArray
    motor_out: FloatArray
    cmd: FloatArray
    collided: BoolArray
    rolled_m: FloatArray


@dataclass(frozen=True)
class Proposal:
    """The world's proposal for the next tick.

    Attributes:
        pose: (N, 3) proposed poses.
        motor_out: (N, 2) motor outputs after this tick.
        linear: (N,) signed linear motion (legacy collision rule needs its sign).
        rolled_m: (N, 2) how far each wheel rolls this tick.
    """

    pose: FloatArray
    motor_out: FloatArray
    linear: FloatArray
    rolled_m: FloatArray


def initial_state(pose: FloatArray) -> WorldState:
    """A world at rest at ``pose`` (N, 3)."""
    n = len(pose)
    z2 = np.zeros((n, 2))
    return WorldState(0, np.array(pose, dtype=np.float64), z2, z2.copy(), np.zeros(n, dtype=bool), z2.copy())


def propose(
    state: WorldState,
    bodies: Bodies,
    *,
    dt_s: float,
    profile: Profile = Profile.NATIVE,
    noise_z: FloatArray | None = None,
    motors_noise_pct: float = 0.0,
    reported_pose: FloatArray | None = None,
) -> Proposal:
    """Computes every robot's next pose from its motors (or its own report, for Real robots).

    Args:
        state: The current state; ``state.cmd`` holds the powers to apply.
        bodies: The robots.
        dt_s: Tick length (the legacy profile ignores it: its units are per cycle).
        profile: Native or Ciber-Rato.
        noise_z: (N, 2) standard normals for movement noise (native: scaled by each robot's
            motion noise; legacy: by ``motors_noise_pct``). ``None`` means no noise.
        motors_noise_pct: Ciber-Rato MotorsNoise, sigma in percent.
        reported_pose: (N, 3) poses Real robots reported (NaN rows for none); Real robots are
            placed there and their motors are ignored.

    Returns:
        The proposal.
    """
    cmd = clamp_power(state.cmd)
    if profile == Profile.CIBERRATO:
        gain = np.ones_like(cmd) if noise_z is None else 1.0 + motors_noise_pct / 100.0 * noise_z
        nxt, out = step_drive_ciberrato(state.pose, state.motor_out, cmd, gain)
        rolled = out.copy()
    else:
        mean = bodies.noise_mean["motion"][:, None]
        std = bodies.noise_std["motion"][:, None]
        noise = None if noise_z is None else mean + std * noise_z
        nxt, out = step_drive(state.pose, state.motor_out, cmd, bodies.drive, dt_s, speed_noise=noise)
        rolled = wheel_speeds_mps(out, bodies.drive.max_speed_mps) * dt_s
    linear = 0.5 * (out[:, 0] + out[:, 1])
    real = _real(bodies)
    if reported_pose is not None and real.any():
        have = real & np.all(np.isfinite(reported_pose), axis=1)
        nxt = np.where(have[:, None], reported_pose, nxt)
        hold = real & ~have
        nxt = np.where(hold[:, None], state.pose, nxt)
    return Proposal(nxt, out, linear, rolled)


@lru_cache(maxsize=8)
def _real(bodies: Bodies) -> npt.NDArray[np.bool_]:
    """(N,) which robots are Real (read-only; worked out once per roster, Bodies hash by identity)."""
    real = np.asarray([t == RobotType.REAL for t in bodies.types], dtype=bool)
    real.setflags(write=False)
    return real


def commit(
    state: WorldState,
    proposal: Proposal,
    collisions: Collisions,
    *,
    profile: Profile = Profile.NATIVE,
    hold: BoolArray | None = None,
) -> WorldState:
    """Takes the proposal where it does not collide.

    Native: a colliding robot keeps its whole pose. Legacy: it keeps x and y and takes the new
    heading. Robots in ``hold`` (stopped, or every robot while no collision check answers) keep
    their pose and their motors do not advance.

    Args:
        state: The current state.
        proposal: The proposal for this tick.
        collisions: The verdict on it.
        profile: Native or Ciber-Rato.
        hold: (N,) robots that must not move this tick.

    Returns:
        The next state.
    """
    n = len(state.pose)
    held = np.zeros(n, dtype=bool) if hold is None else np.asarray(hold, dtype=bool)
    hit = collisions.collided
    pose = proposal.pose.copy()
    if profile == Profile.CIBERRATO:
        pose[hit, 0:2] = state.pose[hit, 0:2]
    else:
        pose[hit] = state.pose[hit]
    pose[held] = state.pose[held]
    out = np.where(held[:, None], state.motor_out, proposal.motor_out)
    rolled = np.where(held[:, None], 0.0, proposal.rolled_m)
    # the constructor rather than dataclasses.replace (which costs more than the commit on a few robots)
    return WorldState(state.tick + 1, pose, out, state.cmd, hit & ~held, rolled)


def step(
    state: WorldState,
    bodies: Bodies,
    scene: Scene,
    *,
    dt_s: float,
    profile: Profile = Profile.NATIVE,
    noise_z: FloatArray | None = None,
    motors_noise_pct: float = 0.0,
) -> tuple[WorldState, Collisions]:
    """One whole tick in one process: propose, check, commit.

    Returns:
        ``(next_state, collisions)``.
    """
    prop = propose(state, bodies, dt_s=dt_s, profile=profile, noise_z=noise_z, motors_noise_pct=motors_noise_pct)
    if profile == Profile.CIBERRATO:
        col = check_collisions_ciberrato(scene, state.pose, prop.pose, prop.linear)
    else:
        col = check_collisions(scene, bodies.outline, state.pose, prop.pose)
    return commit(state, prop, col, profile=profile), col
