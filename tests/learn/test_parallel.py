"""The PettingZoo environment: one agent per chair passes PettingZoo's own API and seed tests; a
chair that collides or arrives leaves the agents and stands still; a scenario's robots with goals
are the agents, its other robots driven by their own agents in-process."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test, parallel_seed_test

import iw_zenoh.learn
from iw_zenoh.errors import IwError
from iw_zenoh.learn.parallel import ChairsEnv
from tests.integration.harness import MAPS


def test_the_default_world_of_several_chairs_passes_pettingzoos_api_test() -> None:
    env = iw_zenoh.learn.parallel_env()
    parallel_api_test(env, num_cycles=100)
    obs, _ = env.reset(seed=2)
    assert len(obs) == 4
    assert all(env.observation_space(a).contains(o) for a, o in obs.items())


def test_the_same_seed_gives_the_same_episode() -> None:
    parallel_seed_test(lambda: iw_zenoh.learn.parallel_env(chairs=3, action="wheels"))


def test_a_chair_done_leaves_the_agents_and_stands_still_among_the_others() -> None:
    env = ChairsEnv(chairs=3, max_steps=3000, render_mode="rgb_array")
    env.reset(seed=5)
    gone: dict[str, int] = {}
    for _ in range(3000):
        if len(env.agents) < 3:
            break
        _, _, terms, truncs, _ = env.step({a: np.array([1.0, 0.0], dtype=np.float32) for a in env.agents})
        gone.update({a: i for i, a in enumerate(env.possible_agents, start=1) if terms.get(a)})
    assert gone, "driving straight on, some chair met a wall or a chair"
    assert env.episode is not None
    name, rid = next(iter(gone.items()))
    assert name not in env.agents
    state = env.episode.last.state
    at = state.ids.index(rid)
    before = (state.x[at], state.y[at])
    for _ in range(5):
        env.step({a: np.array([1.0, 0.0], dtype=np.float32) for a in env.agents})
    state = env.episode.last.state
    assert (state.x[at], state.y[at]) == pytest.approx(before, abs=0.05)  # its motors run down, then stop
    picture = env.render()
    assert isinstance(picture, np.ndarray)
    assert picture.shape[2] == 3


def test_a_scenarios_robots_with_goals_are_the_agents_and_the_others_drive_themselves() -> None:
    env = iw_zenoh.learn.parallel_env(scenario=MAPS / "scenarios" / "convoy.toml")
    assert env.possible_agents == ["robot_4", "robot_1"]  # the two with a [[criteria.reach]]
    parallel_api_test(env, num_cycles=20)
    env.reset(seed=3)
    for _ in range(20):
        env.step({a: np.zeros(2, dtype=np.float32) for a in env.agents})
    assert env.episode is not None
    state = env.episode.last.state
    follower = state.ids.index(3)  # robot 3 follows robot 4 in-process: 4 stands still, so 3 stays
    assert state.x[follower] == pytest.approx(8.0, abs=1.0)
    assert env.episode.last.heard[1]  # the in-process agents talk on the radio


def test_a_scenario_with_no_goal_to_learn_is_refused_saying_so(tmp_path: Path) -> None:
    sc = tmp_path / "nogoal.toml"
    grid = MAPS / "hospital-grid.xml"
    sc.write_text(f'[world]\nmap = "{MAPS / "hospital.xml"}"\ngrid = "{grid}"\n[[agents]]\nprogram = "wanderer"\n')
    with pytest.raises(IwError, match="no \\[\\[criteria.reach\\]\\]"):
        iw_zenoh.learn.parallel_env(scenario=sc)
