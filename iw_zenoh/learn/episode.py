"""One learner's episode in a :class:`~iw_zenoh.sim.local.LocalWorld`: its chair driven by the
learner's actions, every other robot by its own agent in-process, observation and reward from
:mod:`iw_zenoh.learn.nav`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from iw_zenoh.agent.hosting import Command
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.learn.nav import Goal, Reward, Senses, goal_distance, to_powers
from iw_zenoh.sim.local import LocalWorld, Step

__all__ = ["Episode", "Outcome"]


@dataclass
class Outcome:
    """One chair's view of a step."""

    obs: np.ndarray
    reward: float
    terminated: bool
    truncated: bool
    info: dict[str, Any]


class Episode:
    """Learners' chairs and in-process agents in one world.

    Args:
        world: The world, its robots registered, not stepped yet.
        goals: Each learner's chair (robot id) and its goal.
        agents: The other robots' agents (``on_sensors(reading, heard) -> Command``), by robot id.
        max_steps: Steps before an episode is truncated.
        action: ``"vw"`` or ``"wheels"`` (:func:`iw_zenoh.learn.nav.to_powers`).
        reward: The reward's terms.
    """

    def __init__(
        self,
        world: LocalWorld,
        goals: Mapping[int, Goal],
        *,
        agents: Mapping[int, Any] | None = None,
        max_steps: int = 600,
        action: str = "vw",
        reward: Reward | None = None,
    ) -> None:
        self.world = world
        self.goals = dict(goals)
        self.agents = dict(agents or {})
        self.max_steps = max_steps
        self.action = action
        self.reward = reward or Reward()
        period_s = world.cfg.period_ms / 1000.0
        self.specs = {rid: world.spec(rid) for rid in self.goals}
        self.senses = {rid: Senses(spec, period_s) for rid, spec in self.specs.items()}
        self.steps = 0
        self._pending: dict[int, Any] = {}
        self.last = self._advance({})
        self._dist = {rid: goal_distance(self.last.state, self._index(rid), g) for rid, g in self.goals.items()}

    def _index(self, rid: int) -> int:
        return self.last.state.ids.index(rid)

    def _advance(self, commands: dict[int, Any]) -> Step:
        """One tick: the learners' commands and the agents' answers to the last readings."""
        s = self.world.step({**self._pending, **commands})
        self._pending = {
            rid: _powers(agent.on_sensors(s.readings[rid], s.heard.get(rid, [])), self.world.spec(rid))
            for rid, agent in self.agents.items()
            if rid in s.readings
        }
        return s

    def observe(self, rid: int) -> np.ndarray:
        """A learner's current observation."""
        return self.senses[rid].observe(self.last.readings[rid], self.last.state, self._index(rid), self.goals[rid])

    def step(self, actions: Mapping[int, np.ndarray]) -> dict[int, Outcome]:
        """Steps the world with each learner's action (a learner given none stands still); the
        outcome of each learner given one."""
        cmds: dict[int, Any] = dict.fromkeys(self.goals, (0.0, 0.0))  # a learner done stands still
        cmds.update({rid: to_powers(a, self.specs[rid], self.action) for rid, a in actions.items()})
        self.last = self._advance(cmds)
        self.steps += 1
        out: dict[int, Outcome] = {}
        for rid in actions:
            goal = self.goals[rid]
            dist = goal_distance(self.last.state, self._index(rid), goal)
            reached = dist < goal.within
            collided = bool(self.last.readings[rid].collision)
            r = self.reward.progress * (self._dist[rid] - dist) + self.reward.time
            r += self.reward.goal if reached else 0.0
            r += self.reward.collision if collided else 0.0
            self._dist[rid] = dist
            info = {"distance": dist, "reached": reached, "collided": collided, "tick": self.last.state.tick}
            truncated = self.steps >= self.max_steps or self.world.stopped
            out[rid] = Outcome(self.observe(rid), float(r), reached or collided, truncated, info)
        return out


def _powers(cmd: Any, spec: RobotSpec) -> Any:
    """An agent's command in wheel powers (a ``Command.from_velocity`` through its chair's model)."""
    return cmd.resolved(spec) if isinstance(cmd, Command) else cmd
