"""One learner's episode in a :class:`~iw_zenoh.sim.local.LocalWorld`: its chair driven by the
learner's actions, every other robot by its own agent in-process, observation and reward from
:mod:`iw_zenoh.learn.nav`."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from iw_zenoh.agent.hosting import Command
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.learn.nav import Goal, Reward, Senses, goal_distance, to_powers
from iw_zenoh.messages import WorldState
from iw_zenoh.sim.local import ArrayStep, LocalWorld, Step

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
        arrays: Step on arrays (:meth:`LocalWorld.step_arrays`: no messages built, the same
            observations and rewards bit for bit) when every robot is a learner's chair; False:
            always on messages.
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
        arrays: bool = True,
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
        # nothing but learners' chairs: the world steps on arrays, no message is built
        self.fast = arrays and not self.agents and set(world.ids) == set(self.goals)
        self.arrays: ArrayStep | None = None
        self._at: tuple[list[int], dict[int, int]] = ([], {})  # the arrays' robots, and each one's index
        self.last = self._advance({})
        self._dist = {rid: self._distance(rid) for rid in self.goals}

    def _index(self, rid: int) -> int:
        if self.arrays is not None:
            return self.arrays.ids.index(rid)
        return self.last.state.ids.index(rid)

    def _distance(self, rid: int) -> float:
        g, i = self.goals[rid], self._index(rid)
        if self.arrays is None:
            return goal_distance(self.last.state, i, g)
        x, y = self.arrays.pose[i, :2].tolist()
        return math.hypot(g.x - x, g.y - y)

    def _collided(self, rid: int) -> bool:
        if self.arrays is None:
            return bool(self.last.readings[rid].collision)
        return bool(self.arrays.collided[self._index(rid)])

    def _advance(self, commands: dict[int, Any]) -> Step:
        """One tick: the learners' commands and the agents' answers to the last readings."""
        if self.fast:
            ids = self.world.array_ids()
            self.arrays = a = self.world.step_arrays(np.asarray([commands.get(rid, (0.0, 0.0)) for rid in ids]))
            return _Lazy(a, self.world)  # type: ignore[return-value]
        s = self.world.step({**self._pending, **commands})
        self._pending = {
            rid: _powers(agent.on_sensors(s.readings[rid], s.heard.get(rid, [])), self.world.spec(rid))
            for rid, agent in self.agents.items()
            if rid in s.readings
        }
        return s

    def observe(self, rid: int, index: int | None = None) -> np.ndarray:
        """A learner's current observation (``index``: its chair's in the arrays, when known)."""
        if self.arrays is not None:
            i = self._index(rid) if index is None else index
            return self.senses[rid].observe_arrays(self.arrays, i, self.goals[rid])
        return self.senses[rid].observe(self.last.readings[rid], self.last.state, self._index(rid), self.goals[rid])

    def step(self, actions: Mapping[int, np.ndarray]) -> dict[int, Outcome]:
        """Steps the world with each learner's action (a learner given none stands still); the
        outcome of each learner given one."""
        if self.fast:
            return self._step_arrays(actions)
        cmds: dict[int, Any] = dict.fromkeys(self.goals, (0.0, 0.0))  # a learner done stands still
        cmds.update({rid: to_powers(a, self.specs[rid], self.action) for rid, a in actions.items()})
        self.last = self._advance(cmds)
        self.steps += 1
        return {rid: self._outcome(rid, self._distance(rid), self._collided(rid)) for rid in actions}

    def _outcome(self, rid: int, dist: float, collided: bool, index: int | None = None) -> Outcome:
        """A learner's outcome of the step just taken, from its distance to its goal and its flag
        (``index``: its chair's in the arrays, when known)."""
        goal, terms = self.goals[rid], self.reward
        reached = dist < goal.within
        r = terms.progress * (self._dist[rid] - dist) + terms.time
        r += terms.goal if reached else 0.0
        r += terms.collision if collided else 0.0
        self._dist[rid] = dist
        info = {"distance": dist, "reached": reached, "collided": collided, "tick": self.world.tick}
        truncated = self.steps >= self.max_steps or self.world.stopped
        return Outcome(self.observe(rid, index), float(r), reached or collided, truncated, info)

    def _step_arrays(self, actions: Mapping[int, np.ndarray]) -> dict[int, Outcome]:
        """:meth:`step` when every robot is a learner's chair: the powers straight into the world's
        arrays (the roster cannot change: no agent adds or removes a robot), the same outcomes."""
        ids = self.world.world.arrays()  # the world's list (a new one when the roster changes)
        if ids is not self._at[0]:
            self._at = (ids, {rid: k for k, rid in enumerate(ids)})
        at = self._at[1]
        powers = np.zeros((len(ids), 2))  # a learner done (given no action) stands still
        for rid, a in actions.items():
            powers[at[rid]] = to_powers(a, self.specs[rid], self.action)
        self.arrays = s = self.world.step_arrays(powers)
        self.last = _Lazy(s, self.world)  # type: ignore[assignment]
        self.steps += 1
        out: dict[int, Outcome] = {}
        pose, collided = s.pose.tolist(), s.collided.tolist()
        for rid in actions:
            g, k = self.goals[rid], at[rid]
            x, y, _ = pose[k]
            out[rid] = self._outcome(rid, math.hypot(g.x - x, g.y - y), collided[k], k)
        return out


class _Lazy:
    """A tick stepped on arrays, as much of a :class:`~iw_zenoh.sim.local.Step` as the
    environments read of it: its state, built only when asked (to render; speeds are not filled)."""

    def __init__(self, a: ArrayStep, world: LocalWorld) -> None:
        self.arrays = a
        self._world = world

    @property
    def state(self) -> WorldState:
        """The tick's committed state message."""
        a, w = self.arrays, self._world.world
        x, y, h = a.pose.T.tolist()
        rl, rr = a.rolled_m.T.tolist()
        n = len(a.ids)
        return WorldState(
            tick=a.tick,
            sim_time_ns=w.sim_time_ns(a.tick),
            revision=w.revision,
            ids=list(a.ids),
            x=x,
            y=y,
            heading=h,
            collided=a.collided.tolist(),
            rolled_left=rl,
            rolled_right=rr,
            speed=[0.0] * n,
        )


def _powers(cmd: Any, spec: RobotSpec) -> Any:
    """An agent's command in wheel powers (a ``Command.from_velocity`` through its chair's model)."""
    return cmd.resolved(spec) if isinstance(cmd, Command) else cmd
