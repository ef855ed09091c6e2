"""``iw_zenoh/ChairNav-v0``: one chair to a goal in a room drawn from a set of maps.

Each ``reset(seed=...)`` draws a room (a generated one, or one of the labs given as ``maps``), a
start pose and a goal from the environment's generator, and seeds the world's noise from it, so
the same seed and actions give the same episode. The world is the simulator's own
(:class:`~iw_zenoh.sim.local.LocalWorld`); observation, action and reward are
:mod:`iw_zenoh.learn.nav`'s.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np

from iw_zenoh.core.lab import Lab
from iw_zenoh.core.spec import LaserSpec, RobotSpec, prototype_chair
from iw_zenoh.errors import IwError
from iw_zenoh.learn.episode import Episode
from iw_zenoh.learn.nav import ACTIONS, Goal, Reward, Senses, clearance_m
from iw_zenoh.learn.render import frame
from iw_zenoh.learn.rooms import random_room, start_and_goal
from iw_zenoh.sim.local import LocalWorld

__all__ = ["ChairNavEnv", "default_chair"]

SEEDS = 2**31 - 1  # the world's seed is drawn below this


def default_chair() -> RobotSpec:
    """The LIACC prototype chair (eight 60-degree sonars of 4 m) with a 64-beam, 270-degree laser of 10 m."""
    laser = LaserSpec(id=0, x_m=0.5, angle_deg=0.0, fov_deg=270.0, beams=64, range_m=10.0)
    return prototype_chair("learner", lasers=(laser,))


class ChairNavEnv(gym.Env[np.ndarray, np.ndarray]):
    """One chair, one goal.

    Args:
        action: ``"vw"`` (linear and turn speed) or ``"wheels"`` (wheel powers), both ``[-1, 1]``.
        maps: Labs to draw rooms from (default: generated rooms, :func:`iw_zenoh.learn.rooms.random_room`).
        chair: The chair (default :func:`default_chair`).
        max_steps: Steps (0.1 s each) before an episode is truncated.
        reward: The reward's terms.
        render_mode: ``None`` or ``"rgb_array"``.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}  # noqa: RUF012 (gymnasium's convention)

    def __init__(
        self,
        *,
        action: str = "vw",
        maps: Sequence[Lab] | None = None,
        chair: RobotSpec | None = None,
        max_steps: int = 600,
        reward: Reward | None = None,
        render_mode: str | None = None,
    ) -> None:
        if action not in ACTIONS:
            raise ValueError(f"action must be one of {ACTIONS}, got {action!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.action_mode = action
        self.maps = list(maps or [])
        self.chair = chair or default_chair()
        self.max_steps = max_steps
        self.reward_terms = reward or Reward()
        self.render_mode = render_mode
        self.episode: Episode | None = None
        self.lab: Lab | None = None
        self.observation_space = Senses(self.chair, 0.1).space
        self.action_space = gym.spaces.Box(-1.0, 1.0, (2,), dtype=np.float32)

    def _world(self, g: np.random.Generator) -> tuple[Lab, LocalWorld, int, Goal]:
        lab = self.maps[int(g.integers(len(self.maps)))] if self.maps else random_room(g)
        margin = clearance_m(self.chair)
        for _ in range(100):
            world = LocalWorld(lab, seed=int(g.integers(SEEDS)), sim="chairnav")
            try:
                (x, y), (gx, gy) = start_and_goal(g, lab, margin)
            except ValueError:
                if self.maps:
                    raise
                lab = random_room(g)  # a room too crowded for a start and a goal: another one
                continue
            spec = replace(self.chair, id=1, x_m=x, y_m=y, dir_deg=float(g.uniform(-180, 180)))
            try:
                return lab, world, world.add(spec), Goal(gx, gy)
            except IwError:
                continue  # the world found it placed on something: draw again
        raise IwError(f"no free start for the chair in {lab.name!r}")

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Draws a room, start and goal from the environment's generator (seeded by ``seed``)."""
        super().reset(seed=seed)
        self.lab, world, rid, goal = self._world(self.np_random)
        self.rid = rid
        self.episode = Episode(
            world, {rid: goal}, max_steps=self.max_steps, action=self.action_mode, reward=self.reward_terms
        )
        return self.episode.observe(rid), {"goal": (goal.x, goal.y), "map": self.lab.name}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One tick (0.1 s) with the chair's action."""
        if self.episode is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        o = self.episode.step({self.rid: action})[self.rid]
        return o.obs, o.reward, o.terminated, o.truncated, o.info

    def render(self) -> np.ndarray | None:
        """The picture (``rgb_array``), or None without a render mode."""
        if self.render_mode is None or self.episode is None or self.lab is None:
            return None
        ep = self.episode
        return frame(self.lab, ep.last.state, {r: ep.world.spec(r) for r in ep.world.ids}, ep.goals)
