"""LocalWorld's array path (``step_arrays``, the learning environments' fast path) runs the same
world, collision check, sensors and noise as its message path (``step``, bit-identical to a
lock-step ``iwz run``): the same seed and commands give the same states and readings, bit for bit,
through collisions, noise, a laser and robots coming and going, and the two paths mix."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from iw_zenoh.core.lab import Grid, GridPosition, Lab
from iw_zenoh.core.spec import LaserSpec, NoiseSpec, RobotSpec, RobotType, prototype_chair
from iw_zenoh.errors import IwError
from iw_zenoh.messages import SensorReading, WorldState
from iw_zenoh.sim.local import ArrayStep, LocalWorld
from tests.support.builders import box_wall

LASER = LaserSpec(id=0, x_m=0.5, angle_deg=0.0, fov_deg=270.0, beams=32, range_m=10.0)


def _chair(name: str) -> RobotSpec:
    c = prototype_chair(name, lasers=(LASER,))
    # noisy motion and lasers too (the prototype's own noise covers its sonars, compass and encoders)
    return replace(c, noise=replace(c.noise, motion=NoiseSpec(0.0, 0.02), laser_m=NoiseSpec(0.0, 0.01)))


def _world(duration_ticks: int = 0) -> LocalWorld:
    lab = Lab("t", 20.0, 10.0, (box_wall(9.0, 0.0, 10.0, 10.0),))
    grid = Grid((GridPosition(2, 5, 0), GridPosition(5, 5, 180), GridPosition(3, 2, 90)))
    w = LocalWorld(lab, grid, seed=11, duration_ticks=duration_ticks)
    w.add(_chair("a"))
    w.add(_chair("b"))
    return w


def _powers(g: np.random.Generator, n: int) -> np.ndarray:
    p = g.uniform(-0.05, 0.15, (n, 2))
    p[:2] = (0.15, 0.15)  # the first two drive head-on: they meet
    return p


def _as_message(a: ArrayStep) -> tuple[list[float], list[float], list[float], list[bool]]:
    x, y, h = a.pose.T.tolist()
    return x, y, h, a.collided.tolist()


def _state(s: WorldState) -> tuple[list[float], list[float], list[float], list[bool]]:
    return s.x, s.y, s.heading, s.collided


def _reading(a: ArrayStep, i: int) -> tuple[object, ...]:
    r = a.readings
    assert r is not None
    own = a.bodies.ir_owner == i
    prox = [None if v == math.inf else v for v in r.proximity_m[own].tolist()]
    beams = [None if v == math.inf else v for v in r.laser_m[a.bodies.lasers.beam_owner == i].tolist()]
    enc = r.encoder_ticks[i].tolist()
    return prox, beams, float(r.compass_deg[i]), (enc[0], enc[1]), bool(r.collision[i])


def _message(m: SensorReading) -> tuple[object, ...]:
    beams = [v for scan in m.lasers or [] for v in scan.ranges]
    return m.proximity_m, beams, m.compass_deg, m.encoders, m.collision


@pytest.mark.parametrize("fused", [True, False], ids=["one compiled call", "kernel by kernel"])
def test_the_array_path_gives_the_message_paths_states_and_readings_bit_for_bit(fused: bool) -> None:
    slow, fast = _world(), _world()
    fast.fused = fused
    g = np.random.default_rng(5)
    collisions = 0
    for t in range(80):
        if t == 30:  # a robot comes, another goes: the roster changes under both paths
            for w in (slow, fast):
                w.add(_chair("c"))
                w.remove(2)
        ids = fast.array_ids()
        p = _powers(g, len(ids))
        s = slow.step({rid: (float(p[i, 0]), float(p[i, 1])) for i, rid in enumerate(ids)})
        a = fast.step_arrays(p)
        assert a.ids == s.state.ids
        assert _as_message(a) == _state(s.state), f"tick {a.tick}"
        for i, rid in enumerate(a.ids):
            assert _reading(a, i) == _message(s.readings[rid]), f"tick {a.tick}, robot {rid}"
        collisions += sum(a.collided.tolist())
    assert collisions > 0
    assert fast.world.collisions == slow.world.collisions > 0
    assert (fast._fixed is not None) == fused  # the tick took the path asked for


def _readings(a: ArrayStep) -> dict[str, list[object]]:
    assert a.readings is not None
    return {k: np.asarray(v).tolist() for k, v in vars(a.readings).items()}


def test_the_fused_tick_gives_every_array_the_kernels_give_one_by_one() -> None:
    """Every field of the state and of the readings (ground, bumpers, GPS, encoders...), the
    world's counts and the sensors' encoder counts, tick after tick, through collisions, noise
    and a roster change, and a world's ``duration_ticks``."""
    one, apart = _world(duration_ticks=50), _world(duration_ticks=50)
    apart.fused = False
    g = np.random.default_rng(7)
    for t in range(60):
        if t == 20:
            for w in (one, apart):
                w.remove(1)
                w.add(_chair("c"))
        p = _powers(g, len(one.array_ids()))
        a, b = one.step_arrays(p), apart.step_arrays(p)
        assert (a.tick, a.ids) == (b.tick, b.ids)
        for got, want in ((a.pose, b.pose), (a.collided, b.collided), (a.rolled_m, b.rolled_m)):
            assert got.tolist() == want.tolist(), f"tick {a.tick}"
        assert _readings(a) == _readings(b), f"tick {a.tick}"
        assert one.world.state.motor_out.tolist() == apart.world.state.motor_out.tolist()
        assert one.world.state.cmd.tolist() == apart.world.state.cmd.tolist()
        assert (one.world.tick, one.world.steps_left) == (apart.world.tick, apart.world.steps_left)
        assert one.sensors._enc.tolist() == apart.sensors._enc.tolist()
        assert (one.world.collisions, one.stopped) == (apart.world.collisions, apart.stopped)
    assert one.world.collisions > 0
    assert one.stopped
    assert one._fixed is not None
    assert apart._fixed is None


def test_the_two_paths_mix_and_a_command_given_on_arrays_stands_in_step() -> None:
    slow, mixed = _world(), _world()
    g = np.random.default_rng(6)
    for t in range(20):
        p = _powers(g, 2)
        s = slow.step({1: tuple(p[0]), 2: tuple(p[1])} if t % 3 else {})
        if t % 3:
            a = mixed.step_arrays(p)
            assert _as_message(a) == _state(s.state)
        else:  # no command: both keep the last ones
            assert _state(mixed.step().state) == _state(s.state)


def test_step_arrays_refuses_wrong_shapes_and_real_robots_with_reasons() -> None:
    w = _world()
    with pytest.raises(IwError, match=r"\(2, 2\) wheel powers"):
        w.step_arrays(np.zeros(3))
    w.add(replace(prototype_chair("real"), type=RobotType.REAL))
    with pytest.raises(IwError, match="Real robot"):
        w.step_arrays(np.zeros((3, 2)))
    assert w.step().state.tick == 1  # the world is unharmed: step() goes on


def test_a_moved_robot_is_at_rest_at_its_new_pose_and_the_roster_stays() -> None:
    w = _world()
    ids = w.array_ids()
    for _ in range(40):  # both drive ahead: "a" toward "b", "b" toward the wall
        s = w.step_arrays(np.full((2, 2), 0.15), sense=False)
    assert s.collided.any()
    revision, bodies = w.world.revision, s.bodies
    w.move(ids[0], 15.0, 5.0, 90.0)
    after = w.step_arrays(np.zeros((2, 2)))
    assert w.world.revision == revision  # nothing per roster built again
    assert after.bodies is bodies
    assert after.pose[0].tolist() == [15.0, 5.0, math.radians(90.0)]  # at rest: its motors cleared
    assert after.rolled_m[0].tolist() == [0.0, 0.0]
    assert not after.collided[0]
    assert w.array_ids() == ids


def test_a_move_onto_a_wall_or_a_robot_or_of_no_robot_is_refused_and_changes_nothing() -> None:
    w = _world()
    ids = w.array_ids()
    w.step_arrays(np.zeros((2, 2)), sense=False)
    pose = w.world.state.pose.copy()
    with pytest.raises(IwError, match="on wall"):
        w.move(ids[0], 9.5, 5.0, 0.0)
    with pytest.raises(IwError, match="on robot"):
        w.move(ids[0], 5.2, 5.0, 0.0)
    with pytest.raises(IwError, match="outside the lab"):
        w.move(ids[0], 25.0, 5.0, 0.0)
    with pytest.raises(IwError, match="no robot 99"):
        w.move(99, 1.0, 1.0, 0.0)
    assert np.array_equal(w.world.state.pose, pose)


def test_each_moved_robot_is_checked_with_its_own_body_however_often_it_moves() -> None:
    """A move checks the robot's own body (kept while its spec stays, not built a move): a
    small robot fits beside the wall where the big chair does not, again and again."""
    lab = Lab("t", 20.0, 10.0, (box_wall(9.0, 0.0, 10.0, 10.0),))
    w = LocalWorld(lab, Grid((GridPosition(2, 5, 0), GridPosition(5, 2, 0))), seed=1)
    big = w.add(prototype_chair("big"))
    small = w.add(replace(prototype_chair("small"), width_m=0.3, height_m=0.3))
    w.step_arrays(np.zeros((2, 2)), sense=False)
    for y in (3.0, 6.0, 8.0):
        w.move(small, 8.7, y, 0.0)  # 0.3 m from the wall: the small body's half is 0.15 m
        with pytest.raises(IwError, match="on wall"):
            w.move(big, 8.7, y + 1.0, 0.0)
        w.move(big, 4.0, y, 0.0)
    assert w.step_arrays(np.zeros((2, 2)), sense=False).pose[:, 0].tolist() == [4.0, 8.7]


def test_a_robot_added_under_a_removed_ones_id_is_stepped_with_its_own_body_on_both_paths() -> None:
    """The world gives a freed id to the next robot: the view takes the new robot's spec (it kept
    the old one by id, so step() moved and sensed the new chair with the old chair's body)."""
    slow, fast = _world(), _world()
    small = replace(_chair("small"), width_m=0.5, height_m=0.4)
    for w in (slow, fast):
        w.step()
        w.remove(1)
        assert w.add(small) == 1  # the freed id
        assert w.view().specs[1].width_m == 0.5
    g = np.random.default_rng(8)
    for _ in range(30):
        p = _powers(g, 2)
        s = slow.step({rid: (float(p[i, 0]), float(p[i, 1])) for i, rid in enumerate(fast.array_ids())})
        a = fast.step_arrays(p)
        assert _as_message(a) == _state(s.state), f"tick {a.tick}"
        for i, rid in enumerate(a.ids):
            assert _reading(a, i) == _message(s.readings[rid]), f"tick {a.tick}, robot {rid}"
