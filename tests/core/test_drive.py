"""The compiled drive (``iw_zenoh.core.drive``) gives what the numpy expressions it replaced gave,
bit for bit: the world's propose and commit for many robots, both profiles, movement noise, Real
robots' reports (NaN rows) and held robots, and every public array function of
``iw_zenoh.core.motor``, on random input with NaN, infinities, huge values and negative zeros.

The ``_old_*`` functions below are those expressions, kept verbatim as the oracle (the code of
``core/motor.py`` and ``core/world.py`` before the kernels).
"""

from __future__ import annotations

import math
from dataclasses import FrozenInstanceError, astuple, fields, replace
from functools import cache

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from iw_zenoh.core import drive
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.collision import Collisions
from iw_zenoh.core.motor import (
    MAX_POWER,
    STRAIGHT_EPS_RAD,
    DriveParams,
    clamp_power,
    integrate_pose,
    step_drive,
    step_drive_ciberrato,
    step_motors,
    wheel_speeds_mps,
)
from iw_zenoh.core.spec import RobotSpec, RobotType
from iw_zenoh.core.world import Profile, Proposal, WorldState, commit, propose, with_cmd

F = npt.NDArray[np.float64]
B = npt.NDArray[np.bool_]

# --- the oracle: the numpy expressions the kernels replaced --------------------------------


def _old_clamp(power: npt.ArrayLike) -> F:
    p = np.asarray(power, dtype=np.float64)
    return np.minimum(np.maximum(np.where(np.isnan(p), 0.0, p), -MAX_POWER), MAX_POWER)


def _old_motors(out_prev: F, cmd: F, curve: F) -> F:
    c = np.asarray(curve, dtype=np.float64)[:, None]
    return np.asarray((1.0 - c) * _old_clamp(cmd) + c * out_prev, dtype=np.float64)


def _old_speeds(out: F, max_speed_mps: F) -> F:
    return np.asarray(out * (np.asarray(max_speed_mps)[:, None] / MAX_POWER), dtype=np.float64)


def _old_integrate(pose: F, wheel_mps: F, wheel_base_m: F, dt_s: float) -> F:
    v = 0.5 * (wheel_mps[:, 0] + wheel_mps[:, 1])
    w = (wheel_mps[:, 1] - wheel_mps[:, 0]) / wheel_base_m
    th = pose[:, 2]
    dth = w * dt_s
    straight = np.abs(dth) < STRAIGHT_EPS_RAD
    safe = np.where(straight, 1.0, dth)
    chord = np.where(straight, v * dt_s, 2.0 * v * dt_s * np.sin(0.5 * dth) / safe)
    mid = th + 0.5 * dth
    out = np.empty_like(pose)
    out[:, 0] = pose[:, 0] + chord * np.cos(mid)
    out[:, 1] = pose[:, 1] + chord * np.sin(mid)
    out[:, 2] = (th + dth + np.pi) % (2.0 * np.pi) - np.pi
    return out


def _old_drive(pose: F, out_prev: F, cmd: F, params: DriveParams, dt_s: float, noise: F | None) -> tuple[F, F]:
    out = _old_motors(out_prev, cmd, params.curve)
    speeds = _old_speeds(out, params.max_speed_mps)
    if noise is not None:
        speeds = speeds * (1.0 + noise)
    return _old_integrate(pose, speeds, params.wheel_base_m, dt_s), out


def _old_ciberrato(pose: F, out_prev: F, cmd: F, motor_gain: F) -> tuple[F, F]:
    out = (0.5 * _old_clamp(cmd) + 0.5 * out_prev) * motor_gain
    lin = 0.5 * (out[:, 1] + out[:, 0])
    rot = (out[:, 1] - out[:, 0]) / 1.0
    th = pose[:, 2]
    nxt = np.empty_like(pose)
    nxt[:, 0] = pose[:, 0] + lin * np.cos(th)
    nxt[:, 1] = pose[:, 1] + lin * np.sin(th)
    t = th + rot
    t = np.where(t > np.pi, t - 2.0 * np.pi, t)
    nxt[:, 2] = np.where(t < -np.pi, t + 2.0 * np.pi, t)
    return nxt, np.asarray(out, dtype=np.float64)


def _old_propose(
    state: WorldState, bodies: Bodies, dt_s: float, profile: Profile, noise_z: F | None, pct: float, reported: F | None
) -> Proposal:
    cmd = _old_clamp(state.cmd)
    if profile == Profile.CIBERRATO:
        gain = np.ones_like(cmd) if noise_z is None else 1.0 + pct / 100.0 * noise_z
        nxt, out = _old_ciberrato(state.pose, state.motor_out, cmd, gain)
        rolled = out.copy()
    else:
        mean = bodies.noise_mean["motion"][:, None]
        std = bodies.noise_std["motion"][:, None]
        noise = None if noise_z is None else mean + std * noise_z
        nxt, out = _old_drive(state.pose, state.motor_out, cmd, bodies.drive, dt_s, noise)
        rolled = _old_speeds(out, bodies.drive.max_speed_mps) * dt_s
    linear = 0.5 * (out[:, 0] + out[:, 1])
    real = np.asarray([t == RobotType.REAL for t in bodies.types], dtype=bool)
    if reported is not None and real.any():
        have = real & np.all(np.isfinite(reported), axis=1)
        nxt = np.where(have[:, None], reported, nxt)
        hold = real & ~have
        nxt = np.where(hold[:, None], state.pose, nxt)
    return Proposal(nxt, out, linear, rolled)


def _old_commit(state: WorldState, proposal: Proposal, hit: B, profile: Profile, hold: B | None) -> WorldState:
    n = len(state.pose)
    held = np.zeros(n, dtype=bool) if hold is None else np.asarray(hold, dtype=bool)
    pose = proposal.pose.copy()
    if profile == Profile.CIBERRATO:
        pose[hit, 0:2] = state.pose[hit, 0:2]
    else:
        pose[hit] = state.pose[hit]
    pose[held] = state.pose[held]
    out = np.where(held[:, None], state.motor_out, proposal.motor_out)
    rolled = np.where(held[:, None], 0.0, proposal.rolled_m)
    return WorldState(state.tick + 1, pose, out, state.cmd, hit & ~held, rolled)


# --- inputs -----------------------------------------------------------------------------------

SPECIAL = [math.nan, math.inf, -math.inf, -0.0, 0.0, 1e308, -1e308, 5e-324, 1e-13, MAX_POWER, -MAX_POWER]


def _values(lo: float, hi: float) -> st.SearchStrategy[float]:
    """Mostly ordinary values in [lo, hi], sometimes a special one or any float at all."""
    return st.one_of(
        st.floats(lo, hi), st.floats(lo, hi), st.floats(lo, hi), st.sampled_from(SPECIAL), st.floats(width=64)
    )


def _grid(n: int, k: int, lo: float, hi: float) -> st.SearchStrategy[F]:
    return arrays(np.float64, (n, k), elements=_values(lo, hi))


def _column(n: int, lo: float, hi: float) -> st.SearchStrategy[F]:
    return arrays(np.float64, (n,), elements=_values(lo, hi))


@cache
def _base(n: int) -> Bodies:
    return Bodies.from_specs([RobotSpec(f"r{i}", id=i + 1) for i in range(n)])


@st.composite
def _worlds(draw: st.DrawFn) -> tuple[WorldState, Bodies]:
    """A world of 1 to 12 robots: any poses, motor outputs and commands, drive constants and
    motion noise, some robots Real."""
    n = draw(st.integers(1, 12))
    bodies = replace(
        _base(n),
        types=tuple(draw(st.sampled_from([RobotType.SIMULATED, RobotType.REAL])) for _ in range(n)),
        drive=DriveParams(draw(_column(n, 0.0, 3.0)), draw(_column(n, 0.0, 1.0)), draw(_column(n, -1.0, 2.0))),
        noise_mean={"motion": draw(_column(n, -0.1, 0.1))},
        noise_std={"motion": draw(_column(n, 0.0, 0.2))},
    )
    state = WorldState(
        draw(st.integers(0, 10**6)),
        draw(_grid(n, 3, -30.0, 30.0)),
        draw(_grid(n, 2, -0.2, 0.2)),
        draw(_grid(n, 2, -1.0, 1.0)),
        draw(arrays(np.bool_, (n,))),
        draw(_grid(n, 2, -1.0, 1.0)),
    )
    return state, bodies


def _same(got: npt.ArrayLike, want: npt.ArrayLike) -> None:
    """Equal values, NaN where NaN, and the same sign on every zero (a NaN's sign and payload are
    not kept by either: x86 gives a NaN operand's or its default NaN, whichever the compiler's
    operand order makes it)."""
    g, w = np.asarray(got), np.asarray(want)
    assert g.dtype == w.dtype
    np.testing.assert_array_equal(g, w, strict=True)
    if g.dtype == np.float64:
        np.testing.assert_array_equal(np.signbit(g) & ~np.isnan(g), np.signbit(w) & ~np.isnan(w))


# --- the world's tick -------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(
    world=_worlds(),
    ciberrato=st.booleans(),
    noisy=st.booleans(),
    reported=st.booleans(),
    dt_s=st.one_of(st.floats(0.001, 1.0), st.sampled_from([0.0, 0.1, 0.05])),
    pct=st.one_of(st.floats(0.0, 50.0), st.sampled_from([0.0, 1.5])),
    data=st.data(),
)
def test_propose_is_the_numpy_expressions_bit_for_bit(
    world: tuple[WorldState, Bodies],
    ciberrato: bool,
    noisy: bool,
    reported: bool,
    dt_s: float,
    pct: float,
    data: st.DataObject,
) -> None:
    state, bodies = world
    n = len(state.pose)
    profile = Profile.CIBERRATO if ciberrato else Profile.NATIVE
    z = data.draw(_grid(n, 2, -4.0, 4.0)) if noisy else None
    rows = data.draw(_grid(n, 3, -30.0, 30.0)) if reported else None  # NaN rows: no report
    got = propose(state, bodies, dt_s=dt_s, profile=profile, noise_z=z, motors_noise_pct=pct, reported_pose=rows)
    with np.errstate(all="ignore"):
        want = _old_propose(state, bodies, dt_s, profile, z, pct, rows)
    for name in ("pose", "motor_out", "linear", "rolled_m"):
        _same(getattr(got, name), getattr(want, name))


@settings(max_examples=300, deadline=None)
@given(world=_worlds(), ciberrato=st.booleans(), some_held=st.booleans(), data=st.data())
def test_commit_is_the_numpy_expressions_bit_for_bit(
    world: tuple[WorldState, Bodies], ciberrato: bool, some_held: bool, data: st.DataObject
) -> None:
    state, _ = world
    n = len(state.pose)
    prop = Proposal(
        data.draw(_grid(n, 3, -30.0, 30.0)),
        data.draw(_grid(n, 2, -0.2, 0.2)),
        data.draw(_column(n, -0.2, 0.2)),
        data.draw(_grid(n, 2, -1.0, 1.0)),
    )
    hit = data.draw(arrays(np.bool_, (n,)))
    hold = data.draw(arrays(np.bool_, (n,))) if some_held else None
    profile = Profile.CIBERRATO if ciberrato else Profile.NATIVE
    empty = np.zeros((0, 2), dtype=np.int64)
    got = commit(state, prop, Collisions(hit, hit.copy(), hit.copy(), empty, empty), profile=profile, hold=hold)
    want = _old_commit(state, prop, hit, profile, hold)
    assert got.tick == want.tick
    assert got.cmd is state.cmd
    for name in ("pose", "motor_out", "collided", "rolled_m"):
        _same(getattr(got, name), getattr(want, name))


def test_ticks_chained_stay_the_numpy_expressions_with_noise_reports_and_holds() -> None:
    rng = np.random.default_rng(36)
    n = 40
    specs = [RobotSpec(f"r{i}", id=i + 1, type=RobotType.REAL if i % 7 == 3 else RobotType.SIMULATED) for i in range(n)]
    base = Bodies.from_specs(specs)
    bodies = replace(
        base,
        drive=DriveParams(rng.uniform(0.3, 2.0, n), rng.uniform(0.0, 0.95, n), rng.uniform(0.4, 1.2, n)),
        noise_mean={"motion": rng.normal(0.0, 0.01, n)},
        noise_std={"motion": rng.uniform(0.0, 0.1, n)},
    )
    for profile in (Profile.NATIVE, Profile.CIBERRATO):
        pose = np.column_stack([rng.uniform(0, 20, n), rng.uniform(0, 10, n), rng.uniform(-np.pi, np.pi, n)])
        zeros = np.zeros((n, 2))
        got = want = WorldState(0, pose, zeros, zeros, np.zeros(n, dtype=bool), zeros)
        for _ in range(200):
            cmd = rng.uniform(-0.3, 0.3, (n, 2))
            cmd[rng.random((n, 2)) < 0.02] = np.nan
            z = rng.standard_normal((n, 2))
            rows = np.where(rng.random((n, 1)) < 0.5, got.pose + 0.01, np.nan)
            hit, hold = rng.random(n) < 0.1, (rng.random(n) < 0.05 if rng.random() < 0.5 else None)
            got, want = replace(got, cmd=cmd), replace(want, cmd=cmd)
            p_got = propose(got, bodies, dt_s=0.1, profile=profile, noise_z=z, motors_noise_pct=2.0, reported_pose=rows)
            p_want = _old_propose(want, bodies, 0.1, profile, z, 2.0, rows)
            got = commit(got, p_got, Collisions.none(n) if not hit.any() else _hits(hit), profile=profile, hold=hold)
            want = _old_commit(want, p_want, hit, profile, hold)
        assert got.tick == want.tick == 200
        _same(got.pose, want.pose)
        _same(got.motor_out, want.motor_out)
        _same(got.rolled_m, want.rolled_m)


def _hits(hit: B) -> Collisions:
    empty = np.zeros((0, 2), dtype=np.int64)
    return Collisions(hit, hit.copy(), hit.copy(), empty, empty)


def test_read_only_or_strided_inputs_give_the_same_without_compiling_again() -> None:
    bodies = _base(3)
    rng = np.random.default_rng(1)
    pose = rng.uniform(0, 5, (3, 3))
    state = WorldState(0, pose, rng.uniform(-0.1, 0.1, (3, 2)), rng.uniform(-0.2, 0.2, (3, 2)), np.zeros(3, bool), pose)
    plain = propose(state, bodies, dt_s=0.1)
    before = len(drive.propose_into.signatures)
    frozen = [np.array(a) for a in (state.pose, state.motor_out)]
    for a in frozen:
        a.setflags(write=False)
    strided = np.asfortranarray(state.cmd)  # also a view of another layout
    odd = WorldState(0, frozen[0], frozen[1], strided, state.collided, state.rolled_m)
    again = propose(odd, bodies, dt_s=0.1)
    _same(again.pose, plain.pose)
    _same(again.motor_out, plain.motor_out)
    assert len(drive.propose_into.signatures) == before  # one compiled version serves every caller


# --- core.motor's array functions --------------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(
    n=st.integers(1, 10),
    dt_s=st.one_of(st.floats(0.001, 1.0), st.just(0.1)),
    noisy=st.booleans(),
    data=st.data(),
)
def test_motor_array_functions_are_the_numpy_expressions_bit_for_bit(
    n: int, dt_s: float, noisy: bool, data: st.DataObject
) -> None:
    pose, prev, cmd = data.draw(_grid(n, 3, -30, 30)), data.draw(_grid(n, 2, -0.2, 0.2)), data.draw(_grid(n, 2, -1, 1))
    curve, top, base = data.draw(_column(n, 0, 1)), data.draw(_column(n, 0, 3)), data.draw(_column(n, -1, 2))
    wheels, gain = data.draw(_grid(n, 2, -3, 3)), data.draw(_grid(n, 2, 0.5, 1.5))
    noise = data.draw(_grid(n, 2, -0.3, 0.3)) if noisy else None
    params = DriveParams(top, curve, base)
    with np.errstate(all="ignore"):
        _same(clamp_power(cmd), _old_clamp(cmd))
        _same(step_motors(prev, cmd, curve), _old_motors(prev, cmd, curve))
        _same(wheel_speeds_mps(prev, top), _old_speeds(prev, top))
        _same(integrate_pose(pose, wheels, base, dt_s), _old_integrate(pose, wheels, base, dt_s))
        for got, want in zip(
            step_drive(pose, prev, cmd, params, dt_s, speed_noise=noise),
            _old_drive(pose, prev, cmd, params, dt_s, noise),
            strict=True,
        ):
            _same(got, want)
        for got, want in zip(
            step_drive_ciberrato(pose, prev, cmd, gain), _old_ciberrato(pose, prev, cmd, gain), strict=True
        ):
            _same(got, want)


@given(power=_values(-1.0, 1.0))
def test_clamp_power_of_a_scalar_is_a_scalar(power: float) -> None:
    got = clamp_power(power)
    assert np.ndim(got) == 0
    _same(np.float64(got), np.float64(_old_clamp(power)))


def test_the_states_and_proposals_built_without_the_constructor_are_the_constructors() -> None:
    bodies = _base(2)
    rng = np.random.default_rng(3)
    pose = rng.uniform(0, 5, (2, 3))
    start = WorldState(4, pose, np.zeros((2, 2)), np.zeros((2, 2)), np.zeros(2, bool), np.zeros((2, 2)))
    cmd = np.full((2, 2), 0.1)
    commanded = with_cmd(start, cmd)
    assert vars(commanded).keys() == vars(replace(start, cmd=cmd)).keys()
    assert all(getattr(commanded, f.name) is getattr(replace(start, cmd=cmd), f.name) for f in fields(WorldState))
    prop = propose(commanded, bodies, dt_s=0.1)
    state = commit(commanded, prop, Collisions.none(2))
    for built, cls in ((commanded, WorldState), (prop, Proposal), (state, WorldState)):
        assert type(built) is cls
        assert len(astuple(built)) == len(fields(cls))  # every field set
        assert repr(built).startswith(cls.__name__)
        with pytest.raises(FrozenInstanceError):
            built.pose = pose  # type: ignore[misc]
    assert state.tick == 5


def test_arrays_that_do_not_fit_the_robots_are_refused_not_read_past() -> None:
    # the kernels index without bounds checks: a wrong shape must stop them (numpy refused it too)
    bodies = _base(3)
    state = WorldState(0, np.zeros((3, 3)), np.zeros((3, 2)), np.zeros((3, 2)), np.zeros(3, bool), np.zeros((3, 2)))
    for bad in (
        replace(state, cmd=np.zeros((2, 2))),
        replace(state, motor_out=np.zeros((4, 2))),
        replace(state, pose=np.zeros((3, 2))),
    ):
        with pytest.raises(ValueError, match="shape does not fit"):
            propose(bad, bodies, dt_s=0.1)
    with pytest.raises(ValueError, match="shape does not fit"):
        propose(state, bodies, dt_s=0.1, noise_z=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="shape does not fit"):
        propose(state, bodies, dt_s=0.1, reported_pose=np.zeros((1, 3)))
    prop = propose(state, bodies, dt_s=0.1)
    with pytest.raises(ValueError, match="length is not"):
        commit(state, prop, Collisions.none(2))
    with pytest.raises(ValueError, match="length is not"):
        commit(state, prop, Collisions.none(3), hold=np.ones(5, bool))
    with pytest.raises(ValueError, match="shape does not fit"):
        integrate_pose(np.zeros((2, 3)), np.zeros((3, 2)), np.ones(2), 0.1)
