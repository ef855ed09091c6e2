"""ChairNav's episodes step on LocalWorld's array path (no messages built) and give, bit for bit,
the observations, rewards and ends of the message path the distributed run shares."""

from __future__ import annotations

import numpy as np

from iw_zenoh.learn.chairnav import ChairNavEnv
from iw_zenoh.learn.episode import Episode


def _episode(seed: int, arrays: bool) -> tuple[Episode, int]:
    env = ChairNavEnv()
    env.reset(seed=seed)  # draws the room, start, goal and world seed
    g = np.random.default_rng(seed)
    _, world, rid, goal = env._world(g)
    return Episode(world, {rid: goal}, arrays=arrays), rid


def test_chairnav_on_arrays_observes_and_rewards_as_on_messages_bit_for_bit() -> None:
    ends = 0
    for seed in (1, 2):
        fast, rid = _episode(seed, arrays=True)
        slow, _ = _episode(seed, arrays=False)
        assert fast.fast
        assert not slow.fast
        assert np.array_equal(fast.observe(rid), slow.observe(rid))
        g = np.random.default_rng(seed)
        for _ in range(400):
            action = np.asarray([1.0, g.uniform(-0.3, 0.3)])  # full speed ahead: a wall or a box is met
            a, b = fast.step({rid: action})[rid], slow.step({rid: action})[rid]
            assert np.array_equal(a.obs, b.obs)
            assert (a.reward, a.terminated, a.truncated, a.info) == (b.reward, b.terminated, b.truncated, b.info)
            if a.terminated:
                ends += 1
                break
    assert ends > 0  # some episode ended (a collision or the goal) on both paths alike


def test_a_rendered_fast_episode_draws_its_state() -> None:
    env = ChairNavEnv(render_mode="rgb_array")
    env.reset(seed=4)
    assert env.episode is not None
    assert env.episode.fast
    env.step(np.asarray([0.5, 0.0], dtype=np.float32))
    picture = env.render()
    assert picture is not None
    assert picture.ndim == 3
