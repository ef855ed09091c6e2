"""The batched vector environment: N chairs in N walled rooms of one world, stepped in one call,
with Gymnasium's vector API (batched spaces, next-step autoreset) and reproducible seeding."""

from __future__ import annotations

import math

import numpy as np
import pytest

from iw_zenoh.core.lab import Lab
from iw_zenoh.learn.rooms import free_point, start_and_goal
from iw_zenoh.learn.vector import ChairVectorEnv, vector_env


def _run(env: ChairVectorEnv, seed: int, steps: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    obs, _ = env.reset(seed=seed)
    g = np.random.default_rng(seed)
    out = [(obs, np.zeros(env.num_envs), np.zeros(env.num_envs, dtype=bool))]
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(g.uniform(-1, 1, (env.num_envs, 2)).astype(np.float32))
        assert env.observation_space.contains(obs)
        out.append((obs, reward, terminated | truncated))
    return out


def test_a_batch_steps_every_chair_in_one_call_with_batched_spaces() -> None:
    env = vector_env(6)
    obs, _ = env.reset(seed=3)
    assert obs.shape == (6, *env.senses.space.shape)
    assert env.observation_space.contains(obs)
    assert env.action_space.shape == (6, 2)
    obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
    assert obs.shape[0] == reward.shape[0] == terminated.shape[0] == truncated.shape[0] == 6


def test_the_same_seed_gives_the_same_batch() -> None:
    a, b = _run(vector_env(4), 5, 30), _run(vector_env(4), 5, 30)
    for (oa, ra, da), (ob, rb, db) in zip(a, b, strict=True):
        assert np.array_equal(oa, ob)
        assert np.array_equal(ra, rb)
        assert np.array_equal(da, db)


def test_an_environment_that_ended_starts_again_at_its_next_step() -> None:
    env = vector_env(4, max_steps=5)  # every chair truncated at its fifth step
    env.reset(seed=1)
    hold = np.zeros((4, 2), dtype=np.float32)
    for _ in range(4):
        _, _, _, truncated, _ = env.step(hold)
        assert not truncated.any()
    before = list(env.rid)
    assert env.world is not None
    revision, poses = env.world.world.revision, env.world.world.state.pose[:, :2].copy()
    _, _, _, truncated, _ = env.step(hold)
    assert truncated.all()
    obs, reward, terminated, truncated, _ = env.step(hold)  # the autoreset step: first observations
    assert np.array_equal(reward, np.zeros(4))
    assert not (terminated | truncated).any()
    assert env.observation_space.contains(obs)
    assert env.rid == before  # the same chairs, moved: the roster (and all built for it) did not change
    assert env.world is not None
    assert env.world.world.revision == revision
    assert not np.array_equal(env.world.world.state.pose[:, :2], poses)  # each at a new start


def test_no_sensor_search_reaches_another_rooms_walls() -> None:
    """The rooms lie further apart than a chair's sensors reach (laser and cones: mounting point
    plus range), so a sensor's search box, wherever the chair is in its room, holds its own room's
    walls only: the kernels' work does not grow with the rooms packed around it."""
    env = vector_env(9)
    env.reset(seed=2)
    assert env.world is not None
    spec = env.chair
    mounted = [(a.x_m, a.y_m, a.range_m) for a in spec.lasers]
    mounted += [(s.x_m, s.y_m, s.range_m) for s in env.world.spec(env.rid[0]).ir_sensors]
    reach = max(math.hypot(x, y) + r for x, y, r in mounted)
    walls = env.world.view().scene.lab.walls
    boxes = [
        (
            min(x for x, _ in w.corners),
            min(y for _, y in w.corners),
            max(x for x, _ in w.corners),
            max(y for _, y in w.corners),
        )
        for w in walls
    ]
    for room, ox, oy in env.rooms:
        x0, y0, x1, y1 = ox - reach, oy - reach, ox + room.width_m + reach, oy + room.height_m + reach
        mine = [
            b
            for b in boxes
            if b[0] >= ox - 0.5
            and b[2] <= ox + room.width_m + 0.5
            and b[1] >= oy - 0.5
            and b[3] <= oy + room.height_m + 0.5
        ]
        near = [b for b in boxes if not (b[0] > x1 or b[2] < x0 or b[1] > y1 or b[3] < y0)]
        assert sorted(near) == sorted(mine)


def test_a_room_with_no_new_start_and_goal_restarts_the_last_episode_backwards() -> None:
    """A sub-environment's room is drawn once; when its restart finds no start and goal two
    margins apart (few free places, the draws missed them), the chair starts at the last goal
    for the last start, rather than the environment raising in the middle of training."""
    env = vector_env(2, max_steps=2)
    env.reset(seed=4)
    (start, goal), (_, ox, oy) = env.pairs[0], env.rooms[0]
    # every free place of the room is closer than two margins to any other: no pair exists
    env.rooms[0] = (Lab("narrow", 2 * env._margin + 0.5, 2 * env._margin + 0.05), ox, oy)
    hold = np.zeros((2, 2), dtype=np.float32)
    env.step(hold)
    _, _, _, truncated, _ = env.step(hold)
    assert truncated.all()
    env.step(hold)  # the restart
    assert env.pairs[0] == (goal, start)
    assert env.world is not None
    at = env.world.array_ids().index(env.rid[0])
    np.testing.assert_allclose(env.world.world.state.pose[at, :2], (goal[0] + ox, goal[1] + oy))
    np.testing.assert_allclose(env.goal_xy[0], (start[0] + ox, start[1] + oy))


def test_a_start_with_no_goal_far_enough_is_drawn_again() -> None:
    """In a 3 m corridor a start in its middle has no place two margins (2 m) away: drawing
    the goal for it fails, so start_and_goal draws another start."""
    lab = Lab("corridor", 5.0, 2.05)
    failed = 0
    for seed in range(40):
        g = np.random.default_rng(seed)
        (x, y), (gx, gy) = start_and_goal(g, lab, 1.0)
        assert 1.0 <= x <= 4.0
        assert 1.0 <= gx <= 4.0
        assert 1.0 <= y <= 1.05
        assert 1.0 <= gy <= 1.05
        assert math.hypot(gx - x, gy - y) >= 2.0
        g = np.random.default_rng(seed)
        start = free_point(g, lab, 1.0)
        try:
            free_point(g, lab, 1.0, away=[start])
        except ValueError:
            failed += 1
    assert failed > 0  # drawing the start once would have failed for some of them
    with pytest.raises(ValueError, match="no start and goal 2 m apart"):
        start_and_goal(np.random.default_rng(0), Lab("tiny", 3.5, 2.05), 1.0)
