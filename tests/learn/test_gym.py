"""The Gymnasium environments: ChairNav-v0 and any scenario pass Gymnasium's own checker, a seed
gives the same episode, actions become the wheel powers the chair's motor model expects, and the
scenario's other agents drive their chairs in-process."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import iw_zenoh.learn
from iw_zenoh.core.motor import MAX_POWER
from iw_zenoh.errors import IwError
from iw_zenoh.learn.nav import to_powers
from tests.integration.harness import MAPS

CONVOY = MAPS / "scenarios" / "convoy.toml"


def _episode(env: gym.Env, seed: int, steps: int) -> list[np.ndarray]:
    obs, _ = env.reset(seed=seed)
    out = [obs]
    g = np.random.default_rng(seed)
    for _ in range(steps):
        obs, _, terminated, truncated, _ = env.step(g.uniform(-1, 1, 2).astype(np.float32))
        out.append(obs)
        if terminated or truncated:
            break
    return out


@pytest.mark.parametrize("action", ["vw", "wheels"])
def test_chairnav_passes_gymnasiums_checker(action: str) -> None:
    env = gym.make("iw_zenoh/ChairNav-v0", action=action, render_mode="rgb_array")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning either (spaces' bounds, dtypes, seeding)
        check_env(env.unwrapped)
    env.reset(seed=1)
    picture = env.render()
    assert isinstance(picture, np.ndarray)
    assert picture.dtype == np.uint8
    assert picture.ndim == 3


def test_chairnav_with_a_seed_gives_the_same_episode_and_another_seed_another() -> None:
    env = gym.make("iw_zenoh/ChairNav-v0")
    a, b = _episode(env, 7, 40), _episode(env, 7, 40)
    assert len(a) == len(b)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not np.array_equal(_episode(env, 8, 0)[0], a[0])


def test_chairnav_ends_at_a_collision_with_its_penalty() -> None:
    env = iw_zenoh.learn.ChairNavEnv(max_steps=2000)
    env.reset(seed=3)
    for _ in range(2000):
        _, reward, terminated, truncated, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        if terminated or truncated:
            break
    assert terminated
    assert info["collided"] or info["reached"]
    assert reward < -5 if info["collided"] else reward > 5


def test_actions_become_powers_through_the_chairs_own_spec() -> None:
    chair = iw_zenoh.learn.default_chair()
    assert to_powers(np.array([1.0, 0.0]), chair, "vw") == pytest.approx((MAX_POWER, MAX_POWER))
    assert to_powers(np.array([0.5, 0.0]), chair, "vw") == pytest.approx((MAX_POWER / 2, MAX_POWER / 2))
    left, right = to_powers(np.array([0.0, 1.0]), chair, "vw")  # the fastest turn: wheels at +-max_speed
    assert (left, right) == pytest.approx((-MAX_POWER, MAX_POWER))
    assert to_powers(np.array([0.2, -0.4]), chair, "wheels") == pytest.approx((0.2 * MAX_POWER, -0.4 * MAX_POWER))
    with pytest.raises(ValueError, match="action must be one of"):
        to_powers(np.array([0.0, 0.0]), chair, "torque")


def test_a_scenario_is_an_environment_with_its_other_agents_in_process() -> None:
    env = iw_zenoh.learn.make_env(CONVOY, robot=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    a, b = _episode(env, 4, 30), _episode(env, 4, 30)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    episode = env.unwrapped.episode  # type: ignore[attr-defined]
    state = episode.last.state
    leader = state.ids.index(4)
    assert state.x[leader] > 11.0 + 0.3  # the convoy's leader drove itself along the corridor
    assert episode.last.heard[1]  # and the learner's chair hears the convoy's radio


def test_a_scenario_env_without_a_goal_for_the_robot_says_how_to_give_one() -> None:
    with pytest.raises(IwError, match="no \\[\\[criteria.reach\\]\\] for robot 2; give make_env a goal"):
        iw_zenoh.learn.make_env(CONVOY, robot=2)
    env = iw_zenoh.learn.make_env(CONVOY, robot=2, goal=(30.0, 9.5))
    obs, info = env.reset(seed=1)
    assert info["goal"] == (30.0, 9.5)
    assert env.observation_space.contains(obs)
