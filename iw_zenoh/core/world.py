"""The world's tick as pure functions: propose next poses, then commit them after the collision
verdict. The world node calls :func:`propose` and :func:`commit` on either side of the
collision process; :func:`step` chains the three for tests, benchmarks and lock-step re-runs.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from iw_zenoh.core import drive
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.collision import Collisions, check_collisions, check_collisions_ciberrato
from iw_zenoh.core.drive import bools, floats
from iw_zenoh.core.lab import Scene
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.spec import RobotType

__all__ = [
    "Profile",  # re-exported: its home is core.modes
    "Proposal",
    "WorldState",
    "commit",
    "commit_flags",
    "committed",
    "drive_table",
    "initial_state",
    "propose",
    "step",
    "with_cmd",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

_NO_NOISE = np.zeros((0, 2))  # no rows: no movement noise (the kernels take arrays, never None)
_NO_REPORT = np.zeros((0, 3))  # no rows: no Real robot's report
_NO_HOLD = np.zeros(0, dtype=np.bool_)  # no rows: nobody held


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


def _state(
    tick: int, pose: FloatArray, motor_out: FloatArray, cmd: FloatArray, collided: BoolArray, rolled_m: FloatArray
) -> WorldState:
    """``WorldState(tick, pose, ...)`` as its constructor makes it, without the frozen dataclass's
    ``object.__setattr__`` per field (2.4 us a state, more than the kernel a tick runs)."""
    s = object.__new__(WorldState)
    d = s.__dict__
    d["tick"] = tick
    d["pose"] = pose
    d["motor_out"] = motor_out
    d["cmd"] = cmd
    d["collided"] = collided
    d["rolled_m"] = rolled_m
    return s


def _proposal(pose: FloatArray, motor_out: FloatArray, linear: FloatArray, rolled_m: FloatArray) -> Proposal:
    """``Proposal(...)`` without the frozen dataclass's ``object.__setattr__`` per field (see :func:`_state`)."""
    p = object.__new__(Proposal)
    d = p.__dict__
    d["pose"], d["motor_out"], d["linear"], d["rolled_m"] = pose, motor_out, linear, rolled_m
    return p


def committed(
    tick: int, pose: FloatArray, motor_out: FloatArray, cmd: FloatArray, collided: BoolArray, rolled_m: FloatArray
) -> WorldState:
    """The state :func:`commit_flags` makes, from arrays committed elsewhere (the fused tick,
    :mod:`iw_zenoh.core.fused`), as cheaply as it makes it."""
    return _state(tick, pose, motor_out, cmd, collided, rolled_m)


def with_cmd(state: WorldState, cmd: FloatArray) -> WorldState:
    """``state`` commanding ``cmd`` (what ``dataclasses.replace(state, cmd=cmd)`` gives, for a
    fifth of its cost: the world does it every tick)."""
    return _state(state.tick, state.pose, state.motor_out, cmd, state.collided, state.rolled_m)


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
    n = len(state.pose)
    nxt, out, linear, rolled = np.empty((n, 3)), np.empty((n, 2)), np.empty(n), np.empty((n, 2))
    drive.propose_into(
        floats(state.pose),
        floats(state.motor_out),
        floats(state.cmd),
        _table(bodies),
        float(dt_s),
        profile == Profile.CIBERRATO,
        _NO_NOISE if noise_z is None else floats(noise_z),
        float(motors_noise_pct),
        _NO_REPORT if reported_pose is None else floats(reported_pose),
        nxt,
        out,
        linear,
        rolled,
    )
    return _proposal(nxt, out, linear, rolled)


def drive_table(bodies: Bodies) -> FloatArray:
    """What the drive's kernel reads of each robot (:func:`_table`: the same array while the bodies stay)."""
    return _table(bodies)


@lru_cache(maxsize=8)
def _table(bodies: Bodies) -> FloatArray:
    """(N, 6) what :func:`~iw_zenoh.core.drive.propose_into` reads of each robot: curve, top
    speed, wheel base, motion noise mean and deviation, 1.0 for a Real robot (worked out once
    per roster, Bodies hash by identity; nothing writes it)."""
    d = bodies.drive
    real = [float(t == RobotType.REAL) for t in bodies.types]
    cols = (d.curve, d.max_speed_mps, d.wheel_base_m, bodies.noise_mean["motion"], bodies.noise_std["motion"], real)
    return np.ascontiguousarray(np.column_stack([np.asarray(c, dtype=np.float64) for c in cols]).reshape(-1, 6))


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
    return commit_flags(state, proposal, collisions.collided, profile=profile, hold=hold)


def commit_flags(
    state: WorldState,
    proposal: Proposal,
    collided: BoolArray,
    *,
    profile: Profile = Profile.NATIVE,
    hold: BoolArray | None = None,
) -> WorldState:
    """:func:`commit` from the verdict's (N,) collision flags alone (what the world process is
    told; it builds no :class:`Collisions`)."""
    n = len(state.pose)
    pose, out, rolled, hit = np.empty((n, 3)), np.empty((n, 2)), np.empty((n, 2)), np.empty(n, dtype=np.bool_)
    drive.commit_into(
        floats(state.pose),
        floats(state.motor_out),
        floats(proposal.pose),
        floats(proposal.motor_out),
        floats(proposal.rolled_m),
        bools(collided),
        _NO_HOLD if hold is None else bools(hold),
        profile == Profile.CIBERRATO,
        pose,
        out,
        rolled,
        hit,
    )
    return _state(state.tick + 1, pose, out, state.cmd, hit, rolled)


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
