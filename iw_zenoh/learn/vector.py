"""``iw_zenoh.learn.vector_env(N)``: N ChairNav environments stepped in one call
(``gymnasium.vector.VectorEnv``).

The N rooms (drawn as ChairNav draws them) are laid side by side, each walled in, in one
:class:`~iw_zenoh.sim.local.LocalWorld`: one step moves, checks and senses every chair in one
pass of the core's vectorized (compiled) kernels, rather than N worlds one after the other. A chair
cannot see or meet another room's chair (the walls between stop rays and bodies). The rooms are
further apart than the chair's sensors reach, so a sensor's search never meets another room's
walls (the sensors' kernels look at every wall within range, seen or not: with rooms packed
side by side, a 10 m laser's search took in the walls of about seven rooms). Observation,
action and reward are ChairNav's; a sub-environment that ends is reset at its next step
(Gymnasium's ``NEXT_STEP`` autoreset: that step returns its first observation, reward 0): its
chair is moved at rest to a new start (:meth:`~iw_zenoh.sim.local.LocalWorld.move`: the same robot,
so nothing built per roster is built again), with a new goal, in the same room.
"""

from __future__ import annotations

import math
import os
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from iw_zenoh.core.lab import Lab, Wall
from iw_zenoh.core.spec import RobotSpec, default_ir_sensors
from iw_zenoh.learn.chairnav import SEEDS, default_chair
from iw_zenoh.learn.nav import ACTIONS, Goal, Reward, Senses, bounded_rows, clearance_m, to_powers_batch
from iw_zenoh.learn.rooms import SIZES, random_room, start_and_goal
from iw_zenoh.sim.local import ArrayStep, LocalWorld

__all__ = ["ChairVectorEnv", "vector_env"]

WALL_M = 0.2  # the walls between rooms
ROOM_TRIES = 100  # rooms drawn for a sub-environment before giving up
_Pair = tuple[tuple[float, float], tuple[float, float]]  # a start and a goal
CELL_W, CELL_H = max(w for w, _ in SIZES) + 2 * WALL_M + 0.5, max(h for _, h in SIZES) + 2 * WALL_M + 0.5


def _walled(room: Lab, ox: float, oy: float) -> list[Wall]:
    """The room's walls moved to ``(ox, oy)``, and four walls around it."""
    w, h, t = room.width_m, room.height_m, WALL_M
    out = [Wall(tuple((x + ox, y + oy) for x, y in wall.corners), wall.height_m) for wall in room.walls]
    for x0, y0, x1, y1 in ((-t, -t, w + t, 0), (-t, h, w + t, h + t), (-t, 0, 0, h), (w, 0, w + t, h)):
        out.append(Wall(((ox + x0, oy + y0), (ox + x1, oy + y0), (ox + x1, oy + y1), (ox + x0, oy + y1)), 2.0))
    return out


class ChairVectorEnv(VectorEnv[np.ndarray, np.ndarray, np.ndarray]):
    """N chairs in N rooms, stepped together (see the module doc).

    Args:
        num_envs: How many environments (chairs, rooms).
        action: ``"vw"`` or ``"wheels"``.
        chair: Every chair's spec (default ChairNav's).
        max_steps: Steps before a sub-environment is truncated.
        reward: The reward's terms.
        threads: Sense the chairs on up to this many threads (numba's; the same readings,
            :mod:`iw_zenoh.core.read_all`); default: as many as the CPUs this process may run
            on (``os.sched_getaffinity``; elsewhere than Linux, the machine's), so ``taskset -c 1`` gives one.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}  # noqa: RUF012 (gymnasium's convention)

    def __init__(
        self,
        num_envs: int,
        *,
        action: str = "vw",
        chair: RobotSpec | None = None,
        max_steps: int = 600,
        reward: Reward | None = None,
        threads: int | None = None,
    ) -> None:
        if action not in ACTIONS:
            raise ValueError(f"action must be one of {ACTIONS}, got {action!r}")
        if num_envs < 1:
            raise ValueError(f"num_envs must be at least 1, got {num_envs}")
        self.num_envs, self.action_mode, self.max_steps = num_envs, action, max_steps
        self.threads = threads if threads is not None else _cpus()
        if self.threads < 1:
            raise ValueError(f"threads must be at least 1, got {threads}")
        self.chair, self.reward_terms = chair or default_chair(), reward or Reward()
        self.senses = Senses(self.chair, 0.1)
        self.single_observation_space = self.senses.space
        self.single_action_space = gym.spaces.Box(-1.0, 1.0, (2,), dtype=np.float32)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._margin = clearance_m(self.chair)
        # a gap between rooms wider than the sensors' reach (see the module doc)
        self._gap = _reach_m(self.chair) + WALL_M + 0.5
        self.within = Goal(0.0, 0.0).within
        self.world: LocalWorld | None = None

    def _place(self, i: int, pair: _Pair | None = None) -> None:
        """Sub-environment ``i``'s chair at a new start (placed at ``reset``, moved at a restart),
        with a new goal (``pair``: the start and goal, room coordinates, already drawn)."""
        assert self.world is not None
        g, (room, ox, oy) = self.np_random, self.rooms[i]
        if pair is None:
            try:
                pair = start_and_goal(g, room, self._margin)
            except ValueError:
                # a room of few free places (the draws missed them): the last episode backwards,
                # its goal free and its start two margins from it (a restart, not a crash mid-training)
                pair = (self.pairs[i][1], self.pairs[i][0])
        (x, y), (gx, gy) = self.pairs[i] = pair
        heading = float(g.uniform(-180, 180))
        if self.rid[i]:  # a restart: the same chair moved, so the roster (and what is built for it) stays
            self.world.move(self.rid[i], x + ox, y + oy, heading)
        else:
            self.rid[i] = self.world.add(
                replace(self.chair, name=f"env-{i}", id=i + 1, x_m=x + ox, y_m=y + oy, dir_deg=heading)
            )
        self.goal_xy[i], self.steps[i] = (gx + ox, gy + oy), 0

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Draws every room, start and goal, and the world's seed."""
        if seed is not None:
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(seed)
        g, n = self.np_random, self.num_envs
        cols = math.ceil(math.sqrt(n))
        self.rooms: list[tuple[Lab, float, float]] = []
        walls: list[Wall] = []
        self.pairs: list[_Pair] = []  # each sub-environment's start and goal, room coordinates
        for i in range(n):
            for _ in range(ROOM_TRIES):  # a room with a start and a goal (one too crowded is drawn again)
                room = random_room(g)
                try:
                    self.pairs.append(start_and_goal(g, room, self._margin))
                    break
                except ValueError:
                    continue
            else:
                raise ValueError(f"no room of {ROOM_TRIES} drawn has a start and a goal for the chair")
            ox, oy = 0.5 + WALL_M + (i % cols) * (CELL_W + self._gap), 0.5 + WALL_M + (i // cols) * (CELL_H + self._gap)
            self.rooms.append((room, ox, oy))
            walls += _walled(room, ox, oy)
        rows = math.ceil(n / cols)
        lab = Lab(f"{n} rooms", cols * (CELL_W + self._gap) + 1.0, rows * (CELL_H + self._gap) + 1.0, tuple(walls))
        self.world = LocalWorld(lab, seed=int(g.integers(SEEDS)), sim="vector", threads=self.threads)
        self.rid = [0] * n
        self.goal_xy = np.zeros((n, 2))
        self.steps = np.zeros(n, dtype=np.int64)
        for i in range(n):
            self._place(i, self.pairs[i])
        s = self.world.step_arrays(np.zeros((n, 2)))
        self._dist = self._distances(s, self._where(s))
        self._ended = np.zeros(n, dtype=bool)
        return self._observe(s, self._where(s)), {}

    def _where(self, s: ArrayStep) -> np.ndarray:
        """(N,) each sub-environment's chair's index in the tick's arrays."""
        at = {rid: k for k, rid in enumerate(s.ids)}
        return np.asarray([at[r] for r in self.rid], dtype=np.int64)

    def _distances(self, s: ArrayStep, idx: np.ndarray) -> np.ndarray:
        """(N,) each chair's distance to its goal, m."""
        return np.asarray(np.hypot(self.goal_xy[:, 0] - s.pose[idx, 0], self.goal_xy[:, 1] - s.pose[idx, 1]))

    def _observe(self, s: ArrayStep, idx: np.ndarray) -> np.ndarray:
        """Every sub-environment's observation (ChairNav's layout, :mod:`iw_zenoh.learn.nav`), at once."""
        r, sn = s.readings, self.senses
        assert r is not None
        n = len(s.ids)
        c = np.radians(r.compass_deg[idx])
        dx, dy = self.goal_xy[:, 0] - s.pose[idx, 0], self.goal_xy[:, 1] - s.pose[idx, 1]
        bearing = np.arctan2(dy, dx) - s.pose[idx, 2]
        rolled = s.rolled_m[idx] / sn.period_s
        tail = np.column_stack([np.sin(c), np.cos(c), np.hypot(dx, dy), np.sin(bearing), np.cos(bearing), rolled])
        prox, laser = r.proximity_m.reshape(n, -1), r.laser_m.reshape(n, -1)
        return bounded_rows(prox, laser, idx, sn.ranges, tail, sn.lo, sn.hi)

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """One tick of every chair; sub-environments that ended at the last step start again."""
        assert self.world is not None, "call reset() before step()"
        n, w = self.num_envs, self.world
        restarted = self._ended
        for k in np.flatnonzero(restarted).tolist():
            self._place(k)
        powers = to_powers_batch(np.asarray(actions, dtype=np.float64).reshape(n, 2), self.chair, self.action_mode)
        powers[restarted] = 0.0  # a chair placed again starts at rest
        ids = w.array_ids()
        at = {rid: k for k, rid in enumerate(ids)}
        idx = np.asarray([at[r] for r in self.rid], dtype=np.int64)
        given = np.zeros((len(ids), 2))
        given[idx] = powers
        s = w.step_arrays(given)
        dist = self._distances(s, idx)
        r = self.reward_terms
        reached, collided = dist < self.within, s.collided[idx]
        reward = r.progress * (self._dist - dist) + r.time + r.goal * reached + r.collision * collided
        self.steps += 1
        term, trunc = reached | collided, self.steps >= self.max_steps
        reward[restarted], term[restarted], trunc[restarted] = 0.0, False, False  # their first observation
        self.steps[restarted] = 0
        self._dist = dist
        self._ended = term | trunc
        return self._observe(s, idx), reward, term, trunc, {}


def _reach_m(chair: RobotSpec) -> float:
    """How far the chair's sensors reach from its centre: a laser's or a cone's mounting point
    and its range."""
    irs = chair.ir_sensors or default_ir_sensors(chair.width_m, chair.height_m, chair.com)
    mounted = [(a.x_m, a.y_m, a.range_m) for a in chair.lasers] + [(s.x_m, s.y_m, s.range_m) for s in irs]
    return max((math.hypot(x, y) + r for x, y, r in mounted), default=0.0)


def _cpus() -> int:
    """The CPUs this process may run on (``os.sched_getaffinity``, Linux), or the machine's."""
    getaffinity = getattr(os, "sched_getaffinity", None)
    return len(getaffinity(0)) if getaffinity else os.cpu_count() or 1


def vector_env(num_envs: int = 8, **kwargs: Any) -> ChairVectorEnv:
    """N ChairNav environments in one world, stepped in one call (keywords as :class:`ChairVectorEnv`'s)."""
    return ChairVectorEnv(num_envs, **kwargs)
