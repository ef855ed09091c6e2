"""docs/examples/ppo_chairnav.py's evaluation helper, on a random policy and a trivial one (the
example's training needs the examples extra: no test trains; this needs only the learn extra)."""

from __future__ import annotations

import gymnasium
import numpy as np

from benchmarks.learn import load_example


def test_the_evaluation_counts_every_episode_once_by_how_it_ended() -> None:
    ex = load_example()
    e = ex.evaluate(ex.random_policy(1), 4, seed=7, max_steps=40)
    assert e.episodes == 4
    assert e.success_rate + e.collision_rate + e.timeout_rate == 1.0
    again = ex.evaluate(ex.random_policy(1), 4, seed=7, max_steps=40)
    assert (again.success_rate, again.collision_rate, again.timeout_rate) == (
        e.success_rate,
        e.collision_rate,
        e.timeout_rate,
    )


def test_a_chair_that_stands_still_times_out_and_the_scale_divides_by_one_to_ten() -> None:
    ex = load_example()
    e = ex.evaluate(lambda obs: np.zeros(2, dtype=np.float32), 2, seed=3, max_steps=20)
    assert e.timeout_rate == 1.0
    assert e.mean_steps_to_goal == 0.0
    import iw_zenoh.learn  # noqa: PLC0415

    box = iw_zenoh.learn.ChairNavEnv().observation_space
    assert isinstance(box, gymnasium.spaces.Box)
    assert np.all(np.abs(box.high / ex.SCALE) <= 100.0)  # the goal's distance bound (1000 m) / 10
    assert np.all(ex.SCALE >= 1.0)
