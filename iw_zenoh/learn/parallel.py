"""``parallel_env(...)``: a PettingZoo ParallelEnv with one agent per chair, for multi-agent
learning (convoys, passing in corridors, doorways).

``parallel_env(scenario="maps/scenarios/convoy.toml")``: the robots of a scenario that have a goal
(``[[criteria.reach]]``) are the agents, the others (doors too) run their own agents in-process.

With no arguments, a default world: four chairs (``chair_1`` ... ``chair_4``), each to its own
goal in a room drawn as ChairNav draws it. Each agent's observation, action and reward are
ChairNav's (:mod:`iw_zenoh.learn.nav`); an agent whose chair reaches its goal or collides is done
(its chair then stands still where it is, an obstacle to the others); all are truncated at
``max_steps``. ``reset(seed=s)`` draws the room, starts, goals and the world's noise from ``s``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from pettingzoo import ParallelEnv

from iw_zenoh.core.lab import Lab
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.errors import IwError
from iw_zenoh.learn.chairnav import SEEDS, default_chair
from iw_zenoh.learn.episode import Episode
from iw_zenoh.learn.nav import ACTIONS, Goal, Reward, Senses, clearance_m
from iw_zenoh.learn.render import frame
from iw_zenoh.learn.rooms import random_room, start_and_goal
from iw_zenoh.learn.scenario import build
from iw_zenoh.scenario.file import load_scenario
from iw_zenoh.sim.local import LocalWorld

__all__ = ["ChairsEnv", "parallel_env"]

DEFAULT_CHAIRS = 4


class ChairsEnv(ParallelEnv[str, np.ndarray, np.ndarray]):  # type: ignore[misc]  # pettingzoo ships no types
    """Several chairs, each to its own goal (see the module doc).

    Args:
        chairs: How many chairs (agents ``chair_1`` ... ``chair_N``).
        action: ``"vw"`` or ``"wheels"``.
        maps: Labs to draw rooms from (default: generated rooms).
        chair: Every chair's spec (default ChairNav's).
        max_steps: Steps before every agent is truncated.
        reward: The reward's terms.
        render_mode: ``None`` or ``"rgb_array"``.
        scenario: A scenario file instead of a room: each robot with a ``[[criteria.reach]]`` is an
            agent (``robot_ID``) with that goal, every other robot (doors included) is driven by its
            own agent in-process; ``reset(seed=s)`` seeds the world with ``s`` (default the
            scenario's) and an episode lasts its ``duration_s``. ``chairs``, ``maps``, ``chair`` and
            ``max_steps`` do not apply.
    """

    metadata = {"name": "iw_zenoh_chairs_v0", "render_modes": ["rgb_array"], "render_fps": 10}  # noqa: RUF012

    def __init__(
        self,
        chairs: int = DEFAULT_CHAIRS,
        *,
        action: str = "vw",
        maps: Sequence[Lab] | None = None,
        chair: RobotSpec | None = None,
        max_steps: int = 600,
        reward: Reward | None = None,
        render_mode: str | None = None,
        scenario: str | Path | None = None,
    ) -> None:
        if action not in ACTIONS:
            raise ValueError(f"action must be one of {ACTIONS}, got {action!r}")
        if chairs < 1:
            raise ValueError(f"chairs must be at least 1, got {chairs}")
        self.chair = chair or default_chair()
        self.action_mode, self.maps, self.max_steps = action, list(maps or []), max_steps
        self.reward_terms, self.render_mode = reward, render_mode
        self.possible_agents = [f"chair_{i}" for i in range(1, chairs + 1)]
        self.agents: list[str] = []
        self._rid = {a: i for i, a in enumerate(self.possible_agents, start=1)}
        obs = Senses(self.chair, 0.1).space
        self._obs_space = dict.fromkeys(self.possible_agents, obs)
        self.scenario = None if scenario is None else load_scenario(scenario)
        self._seed: int | None = None
        if self.scenario is not None:
            self._goals = {r.robot: Goal(r.x_m, r.y_m, r.within_m) for r in self.scenario.criteria.reach}
            if not self._goals:
                raise IwError(f"{scenario}: no [[criteria.reach]]: no robot has a goal to learn")
            world, _ = build(self.scenario, self.scenario.world.seed)
            self.possible_agents = [f"robot_{rid}" for rid in self._goals]
            self._rid = {f"robot_{rid}": rid for rid in self._goals}
            period_s = world.cfg.period_ms / 1000
            self._obs_space = {a: Senses(world.spec(rid), period_s).space for a, rid in self._rid.items()}
        self._act_space = {a: gym.spaces.Box(-1.0, 1.0, (2,), dtype=np.float32) for a in self.possible_agents}
        self.episode: Episode | None = None
        self.lab: Lab | None = None
        self._g = np.random.default_rng()

    def observation_space(self, agent: str) -> gym.spaces.Space[Any]:
        """Every chair's observation space (ChairNav's)."""
        return self._obs_space[agent]

    def action_space(self, agent: str) -> gym.spaces.Space[Any]:
        """Every chair's action space, ``Box(-1, 1, (2,))``."""
        return self._act_space[agent]

    def _world(self) -> tuple[LocalWorld, dict[int, Goal]]:
        g = self._g
        margin = clearance_m(self.chair)
        for _ in range(100):  # a room with a start and a goal for every chair (a crowded one is drawn again)
            lab = self.maps[int(g.integers(len(self.maps)))] if self.maps else random_room(g)
            try:
                pairs: list[tuple[tuple[float, float], tuple[float, float]]] = []
                for _rid in self._rid.values():
                    pairs.append(start_and_goal(g, lab, margin, away=[start for start, _ in pairs]))
            except ValueError:
                if self.maps:
                    raise
                continue
            break
        else:
            raise ValueError(f"no room of 100 drawn has starts and goals for {len(self._rid)} chairs")
        self.lab = lab
        world = LocalWorld(lab, seed=int(g.integers(SEEDS)), sim="chairs")
        goals: dict[int, Goal] = {}
        for rid, ((x, y), (gx, gy)) in zip(self._rid.values(), pairs, strict=True):
            world.add(
                replace(self.chair, name=f"chair_{rid}", id=rid, x_m=x, y_m=y, dir_deg=float(g.uniform(-180, 180)))
            )
            goals[rid] = Goal(gx, gy)
        return world, goals

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        """Draws a room, starts and goals (from ``seed``, when given)."""
        if seed is not None:
            self._g, self._seed = np.random.default_rng(seed), seed
        if self.scenario is not None:
            sc = self.scenario
            world, agents = build(sc, sc.world.seed if self._seed is None else self._seed)
            for rid in self._goals:
                agents.pop(rid, None)
            self.lab = world.world.scene.lab
            self.episode = Episode(
                world,
                self._goals,
                agents=agents,
                max_steps=world.cfg.duration_ticks,
                action=self.action_mode,
                reward=self.reward_terms,
            )
        else:
            world, goals = self._world()
            self.episode = Episode(
                world, goals, max_steps=self.max_steps, action=self.action_mode, reward=self.reward_terms
            )
        goals = self.episode.goals
        self.agents = list(self.possible_agents)
        obs = {a: self.episode.observe(self._rid[a]) for a in self.agents}
        infos = {a: {"goal": (goals[self._rid[a]].x, goals[self._rid[a]].y)} for a in self.agents}
        return obs, infos

    def step(
        self, actions: dict[str, np.ndarray]
    ) -> tuple[dict[str, np.ndarray], dict[str, float], dict[str, bool], dict[str, bool], dict[str, dict[str, Any]]]:
        """One tick with every live agent's action (an agent left out stands still this tick)."""
        assert self.episode is not None, "call reset() before step()"
        given = {self._rid[a]: actions.get(a, np.zeros(2)) for a in self.agents}
        out = self.episode.step(given)
        names = list(self.agents)
        obs = {a: out[self._rid[a]].obs for a in names}
        rewards = {a: out[self._rid[a]].reward for a in names}
        terms = {a: out[self._rid[a]].terminated for a in names}
        truncs = {a: out[self._rid[a]].truncated for a in names}
        infos = {a: out[self._rid[a]].info for a in names}
        self.agents = [a for a in names if not (terms[a] or truncs[a])]
        return obs, rewards, terms, truncs, infos

    def render(self) -> np.ndarray | None:
        """The picture (``rgb_array``), or None without a render mode."""
        if self.render_mode is None or self.episode is None or self.lab is None:
            return None
        ep = self.episode
        return frame(self.lab, ep.last.state, {r: ep.world.spec(r) for r in ep.world.ids}, ep.goals)

    def close(self) -> None:
        """Nothing to release (the world is in-process)."""


def parallel_env(**kwargs: Any) -> ChairsEnv:
    """A ParallelEnv of chairs; keywords as :class:`ChairsEnv`'s (none: four chairs, generated rooms)."""
    return ChairsEnv(**kwargs)
