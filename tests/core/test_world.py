from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.collision import Collisions
from iw_zenoh.core.lab import Lab, Scene
from iw_zenoh.core.noise import Stream, rng_for, standard_normals
from iw_zenoh.core.spec import NoiseSpec, RobotSpec, RobotType, SensorNoise
from iw_zenoh.core.world import Profile, commit, initial_state, propose, step
from iw_zenoh.maps import load_lab

NOISY = SensorNoise(motion=NoiseSpec(0.0, 0.05))


def _run(seed: int, ticks: int = 60) -> np.ndarray:
    scene = Scene(load_lab("maps/liacc.xml"))
    specs = [RobotSpec(f"c{i}", id=i + 1, width_m=1.04, height_m=0.66, com=0.81, noise=NOISY) for i in range(4)]
    bodies = Bodies.from_specs(specs)
    state = initial_state(np.array([[10.0 + 2 * i, 6.1, 0.1 * i] for i in range(4)]))
    rngs = [rng_for(seed, int(i), Stream.MOTION) for i in bodies.ids]
    traj = []
    for t in range(ticks):
        cmd = np.array([[0.15, 0.12 + 0.01 * ((t + i) % 3)] for i in range(4)])
        state = replace(state, cmd=cmd)
        state, _ = step(state, bodies, scene, dt_s=0.1, noise_z=standard_normals(rngs, 2))
        traj.append(state.pose.copy())
    return np.asarray(traj)


def test_same_seed_same_commands_same_trajectory_bit_for_bit() -> None:
    a, b = _run(5), _run(5)
    assert a.tobytes() == b.tobytes()
    assert a.tobytes() != _run(6).tobytes()


def test_a_colliding_robot_keeps_its_pose_and_reads_collision() -> None:
    scene = Scene(Lab("open", 10.0, 10.0))
    bodies = Bodies.from_specs([RobotSpec("c", id=1)])
    state = replace(initial_state(np.array([[0.51, 5.0, math.pi]])), cmd=np.full((1, 2), 0.15))
    nxt, col = step(state, bodies, scene, dt_s=0.1)
    assert col.collided.tolist() == [True]
    assert nxt.collided.tolist() == [True]
    assert nxt.pose.tolist() == state.pose.tolist()


def test_ciberrato_commit_keeps_x_and_y_but_turns() -> None:
    scene = Scene(Lab("open", 28.0, 14.0))
    bodies = Bodies.from_specs([RobotSpec("c", id=1, shape="circle")])  # type: ignore[arg-type]
    state = replace(initial_state(np.array([[0.52, 7.0, math.pi]])), cmd=np.array([[0.05, 0.15]]))
    nxt, col = step(state, bodies, scene, dt_s=0.05, profile=Profile.CIBERRATO)
    assert col.collided.tolist() == [True]
    assert nxt.pose[0, :2].tolist() == [0.52, 7.0]
    assert nxt.pose[0, 2] != state.pose[0, 2]


def test_real_robots_are_placed_where_they_report() -> None:
    bodies = Bodies.from_specs([RobotSpec("r", id=1, type=RobotType.REAL), RobotSpec("s", id=2)])
    state = replace(initial_state(np.array([[2.0, 2.0, 0.0], [5.0, 5.0, 0.0]])), cmd=np.full((2, 2), 0.15))
    report = np.array([[2.3, 2.1, 0.2], [np.nan, np.nan, np.nan]])
    prop = propose(state, bodies, dt_s=0.1, reported_pose=report)
    assert prop.pose[0].tolist() == [2.3, 2.1, 0.2]
    assert prop.pose[1, 0] > 5.0


def test_held_robots_do_not_move_even_without_collision() -> None:
    bodies = Bodies.from_specs([RobotSpec("c", id=1)])
    state = replace(initial_state(np.array([[2.0, 2.0, 0.0]])), cmd=np.full((1, 2), 0.15))
    prop = propose(state, bodies, dt_s=0.1)
    nxt = commit(state, prop, Collisions.none(1), hold=np.array([True]))
    assert nxt.pose.tolist() == state.pose.tolist()
    assert nxt.motor_out.tolist() == state.motor_out.tolist()
