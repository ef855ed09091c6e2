"""The collision check in one compiled call (:mod:`iw_zenoh.core.collide`) against the numpy
glue it replaced, kept here as the oracle: the same flags and the same pairs in the same order,
array for array, for many robots (overlapping ones, on walls, out of the lab), active subsets,
doors (wall-free robots) passing each other or not."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.collision import Collisions, check_collisions
from iw_zenoh.core.contact import touching
from iw_zenoh.core.lab import Lab, Scene, Wall
from iw_zenoh.core.placing import swept_outlines
from iw_zenoh.core.spec import BodyShape, RobotSpec

W, H = 8.0, 6.0
N = 8
coord = st.floats(-1.0, W + 1.0)
angle = st.floats(-2 * math.pi, 2 * math.pi)
odd = st.sampled_from([math.nan, math.inf, -math.inf, -0.0, 1e300])
pose = st.tuples(coord, st.floats(-1.0, H + 1.0), angle)
step = st.tuples(st.floats(-0.8, 0.8), st.floats(-0.8, 0.8), st.floats(-1.5, 1.5))
mask = st.none() | st.lists(st.booleans(), min_size=N, max_size=N)


def _old_check(
    scene: Scene,
    outline: np.ndarray,
    pose_now: np.ndarray,
    pose_next: np.ndarray,
    active: np.ndarray | None,
    ignore_walls: np.ndarray | None,
) -> Collisions:
    """check_collisions as it was: numpy glue around the placing and contact kernels."""
    n = len(pose_now)
    empty = np.zeros((0, 2), dtype=np.int64)
    if n == 0:
        return Collisions.none(0)
    idx = None
    if active is not None and not np.all(active):
        idx = np.flatnonzero(np.asarray(active, dtype=bool))
    free = np.zeros(n, dtype=bool) if ignore_walls is None else np.asarray(ignore_walls, dtype=bool)
    if idx is None:
        o, now, nxt, wall_free = outline, pose_now, pose_next, free
    else:
        o, now, nxt, wall_free = outline[idx], pose_now[idx], pose_next[idx], free[idx]
    f64 = [np.ascontiguousarray(a, dtype=np.float64) for a in (o, now, nxt)]
    c_now, c_mid, c_next = swept_outlines(*f64)
    walls, robots = touching(scene, c_now, c_mid, c_next, wall_free)
    if idx is None:
        wall_pairs = walls if len(walls) else empty
        robot_pairs = robots if len(robots) else empty
    else:
        wall_pairs = np.stack([idx[walls[:, 0]], walls[:, 1]], axis=1) if len(walls) else empty
        robot_pairs = idx[robots] if len(robots) else empty
    hit_wall = np.zeros(n, dtype=bool)
    hit_wall[wall_pairs[:, 0]] = True
    hit_robot = np.zeros(n, dtype=bool)
    hit_robot[robot_pairs.reshape(-1)] = True
    return Collisions(hit_wall | hit_robot, hit_wall, hit_robot, wall_pairs, robot_pairs)


def _old_doors_pass_doors(col: Collisions, doors: np.ndarray) -> Collisions:
    """sim.collision's door rule as it was, applied after the check."""
    pairs = col.robot_pairs
    if len(pairs) == 0 or not doors.any():
        return col
    keep = pairs[~(doors[pairs[:, 0]] & doors[pairs[:, 1]])]
    hit_robot = np.zeros(len(doors), dtype=bool)
    hit_robot[keep.reshape(-1)] = True
    return Collisions(col.hit_wall | hit_robot, col.hit_wall, hit_robot, col.wall_pairs, keep)


def _same(got: Collisions, want: Collisions) -> None:
    for name in ("collided", "hit_wall", "hit_robot", "wall_pairs", "robot_pairs"):
        a, b = getattr(got, name), getattr(want, name)
        assert a.dtype == b.dtype, name
        assert a.shape == b.shape, name
        np.testing.assert_array_equal(a, b, err_msg=name)


SCENE = Scene(
    Lab(
        "t",
        W,
        H,
        (
            Wall(((1.0, 1.0), (2.5, 1.0), (2.5, 1.2), (1.0, 1.2)), 1.0),  # a thin wall
            Wall(((5.0, 3.0), (6.5, 2.2), (6.0, 4.5), (5.6, 3.4)), 1.0),  # not convex
            Wall(((3.9, 4.9), (4.1, 4.9), (4.0, 5.1)), 1.0),  # a post
        ),
    )
)


@settings(max_examples=300, deadline=None)
@example(now=[(3.0, 3.0, 0.0)] * N, moves=[(0.0, 0.0, 0.0)] * N, active=None, free=[True] * N, circle=False, n=N)
@example(now=[(3.0, 3.0, 0.0)] * N, moves=[(0.1, 0.0, 0.0)] * N, active=[False] * N, free=None, circle=True, n=N)
@given(
    now=st.lists(pose, min_size=N, max_size=N),
    moves=st.lists(step, min_size=N, max_size=N),
    active=mask,
    free=mask,
    circle=st.booleans(),
    n=st.integers(1, N),
)
def test_one_call_gives_what_the_glue_gave(now, moves, active, free, circle, n) -> None:  # type: ignore[no-untyped-def]
    shape = dict(shape=BodyShape.CIRCLE, width_m=0.8, height_m=0.8) if circle else dict(width_m=1.0, height_m=0.6)
    bodies = Bodies.from_specs([RobotSpec(f"r{i}", id=i + 1, com=0.7, **shape) for i in range(n)])
    p_now = np.asarray(now[:n], dtype=float)
    p_next = p_now + np.asarray(moves[:n], dtype=float)
    act = None if active is None else np.asarray(active[:n], dtype=bool)
    wall_free = None if free is None else np.asarray(free[:n], dtype=bool)
    want = _old_check(SCENE, bodies.outline, p_now, p_next, act, wall_free)
    got = check_collisions(SCENE, bodies.outline, p_now, p_next, active=act, ignore_walls=wall_free)
    _same(got, want)
    doors = np.zeros(n, dtype=bool) if wall_free is None else wall_free
    want_doors = _old_doors_pass_doors(_old_check(SCENE, bodies.outline, p_now, p_next, act, doors), doors)
    got_doors = check_collisions(
        SCENE, bodies.outline, p_now, p_next, active=act, ignore_walls=doors, pass_each_other=True
    )
    _same(got_doors, want_doors)


@settings(max_examples=100, deadline=None)
@given(
    now=st.lists(pose, min_size=N, max_size=N),
    moves=st.lists(step, min_size=N, max_size=N),
    bad=st.lists(st.tuples(st.integers(0, N - 1), st.integers(0, 2), odd), max_size=3),
    active=mask,
)
def test_nan_inf_huge_and_negative_zero_poses_as_the_glue(now, moves, bad, active) -> None:  # type: ignore[no-untyped-def]
    bodies = Bodies.from_specs([RobotSpec(f"r{i}", id=i + 1, width_m=1.0, height_m=0.6) for i in range(N)])
    p_now = np.asarray(now, dtype=float)
    p_next = p_now + np.asarray(moves, dtype=float)
    for i, k, v in bad:
        p_next[i, k] = v
    act = None if active is None else np.asarray(active, dtype=bool)
    with np.errstate(all="ignore"):
        want = _old_check(SCENE, bodies.outline, p_now, p_next, act, None)
        got = check_collisions(SCENE, bodies.outline, p_now, p_next, active=act)
    _same(got, want)


def test_a_crowd_in_a_wide_lab_as_the_glue() -> None:
    """Hundreds of robots, many overlapping, across many cells: pairs in the same order."""
    rng = np.random.default_rng(7)
    lab = Lab(
        "wide",
        60.0,
        40.0,
        tuple(Wall(((x, 5.0), (x + 0.2, 5.0), (x + 0.2, 35.0), (x, 35.0)), 1.0) for x in range(5, 60, 10)),
    )
    scene = Scene(lab)
    n = 400
    bodies = Bodies.from_specs([RobotSpec(f"r{i}", id=i + 1, width_m=1.0, height_m=0.6) for i in range(n)])
    now = np.column_stack([rng.uniform(-0.5, 60.5, n), rng.uniform(-0.5, 40.5, n), rng.uniform(-4, 4, n)])
    nxt = now + rng.normal(0.0, 0.3, (n, 3))
    active = rng.random(n) < 0.8
    doors = rng.random(n) < 0.1
    for act in (None, active):
        want = _old_check(scene, bodies.outline, now, nxt, act, doors)
        got = check_collisions(scene, bodies.outline, now, nxt, active=act, ignore_walls=doors)
        assert len(want.robot_pairs) > 10  # the crowd does collide
        assert len(want.wall_pairs) > 10
        _same(got, want)
        want = _old_doors_pass_doors(want, doors)
        got = check_collisions(scene, bodies.outline, now, nxt, active=act, ignore_walls=doors, pass_each_other=True)
        _same(got, want)


def test_no_robots() -> None:
    got = check_collisions(SCENE, np.zeros((0, 4, 2)), np.zeros((0, 3)), np.zeros((0, 3)))
    _same(got, Collisions.none(0))


def test_arrays_of_another_length_are_refused() -> None:
    """The kernel reads without bounds checks: a mask or outline of the wrong length is an error."""
    outline = Bodies.from_specs([RobotSpec("r", id=1)]).outline
    one = np.asarray([[3.0, 3.0, 0.0]])
    two = np.asarray([[3.0, 3.0, 0.0], [5.0, 3.0, 0.0]])
    with pytest.raises(ValueError, match="one row per robot"):
        check_collisions(SCENE, outline, two, two)
    with pytest.raises(ValueError, match="one row per robot"):
        check_collisions(SCENE, outline, one, two)
    with pytest.raises(ValueError, match="one row per robot"):
        check_collisions(SCENE, outline, one, one, active=np.ones(2, dtype=bool))
    with pytest.raises(ValueError, match="one row per robot"):
        check_collisions(SCENE, outline, one, one, ignore_walls=np.ones(2, dtype=bool))
    _same(check_collisions(SCENE, outline, one, one, active=np.ones(0, dtype=bool)), Collisions.none(1))
