"""Any scenario as a Gymnasium environment: the learner drives one chair, every other agent of the
scenario runs in-process as ``iwz run`` would run it (the same programs and arguments, answering
the same readings, in lock-step).

``make_env("maps/scenarios/convoy.toml", robot=1)``: the goal is the scenario's
``[[criteria.reach]]`` for that robot (or ``goal=(x, y)``), an episode lasts the scenario's
``duration_s``, and ``reset(seed=s)`` runs the scenario with world seed ``s`` (without a seed, the
scenario's own). Not in-process: a scenario's ``[bridge]`` and ``[chair]`` (a Ciber-Rato client or
a serial chair: processes of their own) and run-time ``[[obstacles]]``; such a scenario is refused.
"""

from __future__ import annotations

import argparse
import contextlib
import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from iw_zenoh.agent.hooks import OnRegistered
from iw_zenoh.agent.programs import add_seed_argument, add_spec_arguments, find_program, make_with_spec
from iw_zenoh.core.lab import Grid
from iw_zenoh.errors import IwError
from iw_zenoh.learn.episode import Episode
from iw_zenoh.learn.nav import ACTIONS, Goal, Reward, Senses
from iw_zenoh.learn.render import frame
from iw_zenoh.maps import load_grid, load_lab
from iw_zenoh.scenario.file import load_scenario
from iw_zenoh.scenario.tables import Scenario
from iw_zenoh.sim.local import LocalWorld

__all__ = ["SCENARIO_ID", "ScenarioEnv", "build", "make_env"]

SCENARIO_ID = "iw_zenoh/Scenario-v0"
DISTRIBUTED_ID = "iw_zenoh/DistributedScenario-v0"  # make_env(..., distributed=True)'s


def _agents(sc: Scenario) -> list[Any]:
    """Every agent of the scenario, made as ``iwz agent`` makes them (in the scenario's folder,
    where its relative paths point)."""
    out: list[Any] = []
    with contextlib.chdir(sc.base):
        for i, a in enumerate(sc.agents):
            program = find_program(a.program)
            p = argparse.ArgumentParser(prog=f"agents[{i}] {a.program}", exit_on_error=False)
            program.add_arguments(p)
            add_spec_arguments(p)
            add_seed_argument(p)
            spec = ["--spec-json", json.dumps(a.spec)] if isinstance(a.spec, dict) else []
            seed = ["--seed", str(sc.agent_seed(i))]  # as iwz run hands it
            args, _ = p.parse_known_args([*seed, *a.argv, *spec])  # the role's own (-v, --batch) do not matter here
            out += make_with_spec(program, args)
    return out


def build(sc: Scenario, seed: int) -> tuple[LocalWorld, dict[int, Any]]:
    """The scenario's world with every agent's robots registered, and the agents by robot id.

    Raises:
        IwError: The scenario needs what does not run in-process, or a robot was refused.
    """
    if sc.bridge is not None or sc.chair is not None or sc.obstacles:
        raise IwError(f"{sc.name}: [bridge], [chair] and [[obstacles]] do not run in-process; use iwz run")
    lab = load_lab(sc.world.map)
    grid = load_grid(sc.world.grid, lab) if sc.world.grid is not None else Grid()
    ticks = int(round(sc.world.duration_s * 1000 / sc.world.period_ms))
    world = LocalWorld(
        lab,
        grid,
        seed=seed,
        profile=sc.world.profile,
        period_ms=sc.world.period_ms,
        sim="scenario",
        duration_ticks=ticks,
    )
    agents: dict[int, Any] = {}
    for agent in _agents(sc):
        rid = world.add(agent.spec())
        if isinstance(agent, OnRegistered):
            agent.on_registered(rid, world.spec(rid))
        agents[rid] = agent
    return world, agents


class ScenarioEnv(gym.Env[np.ndarray, np.ndarray]):
    """A scenario with one chair driven by the learner (see the module doc).

    Args:
        path: The scenario file.
        robot: The robot id the learner drives (its agent in the scenario does not run).
        goal: ``(x, y)`` or ``(x, y, within)`` (default: the scenario's reach criterion for it).
        action: ``"vw"`` or ``"wheels"``.
        reward: The reward's terms.
        render_mode: ``None`` or ``"rgb_array"``.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}  # noqa: RUF012 (gymnasium's convention)

    def __init__(
        self,
        path: str | Path,
        robot: int,
        *,
        goal: tuple[float, ...] | None = None,
        action: str = "vw",
        reward: Reward | None = None,
        render_mode: str | None = None,
    ) -> None:
        if action not in ACTIONS:
            raise ValueError(f"action must be one of {ACTIONS}, got {action!r}")
        self.scenario = load_scenario(path)
        self.robot, self.action_mode, self.reward_terms, self.render_mode = robot, action, reward, render_mode
        if goal is None:
            reach = [r for r in self.scenario.criteria.reach if r.robot == robot]
            if not reach:
                raise IwError(f"{path}: no [[criteria.reach]] for robot {robot}; give make_env a goal=(x, y)")
            goal = (reach[0].x_m, reach[0].y_m, reach[0].within_m)
        self.goal = Goal(*goal)
        world, _ = build(self.scenario, self.scenario.world.seed)
        if robot not in world.ids:
            raise IwError(f"{path}: no robot {robot} in the scenario (its robots: {world.ids})")
        self.observation_space = Senses(world.spec(robot), world.cfg.period_ms / 1000).space
        self.action_space = gym.spaces.Box(-1.0, 1.0, (2,), dtype=np.float32)
        self.episode: Episode | None = None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Starts the scenario again, its world seeded by ``seed`` (default the scenario's)."""
        super().reset(seed=seed)
        world, agents = build(self.scenario, self.scenario.world.seed if seed is None else seed)
        agents.pop(self.robot)
        self.episode = Episode(
            world,
            {self.robot: self.goal},
            agents=agents,
            max_steps=world.cfg.duration_ticks,
            action=self.action_mode,
            reward=self.reward_terms,
        )
        return self.episode.observe(self.robot), {"goal": (self.goal.x, self.goal.y)}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One tick with the learner's action; the other agents answer their readings."""
        if self.episode is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        o = self.episode.step({self.robot: action})[self.robot]
        return o.obs, o.reward, o.terminated, o.truncated, o.info

    def render(self) -> np.ndarray | None:
        """The picture (``rgb_array``), or None without a render mode."""
        if self.render_mode is None or self.episode is None:
            return None
        ep = self.episode
        return frame(ep.world.world.scene.lab, ep.last.state, {r: ep.world.spec(r) for r in ep.world.ids}, ep.goals)


def make_env(
    path: str | Path, robot: int, *, distributed: bool = False, **kwargs: Any
) -> gym.Env[np.ndarray, np.ndarray]:
    """A scenario as an environment, made by Gymnasium (``iw_zenoh/Scenario-v0``, wrapped as
    ``gym.make`` wraps): ``make_env("maps/scenarios/convoy.toml", robot=1)``; keywords as
    :class:`ScenarioEnv`'s. Its :class:`ScenarioEnv` is ``env.unwrapped``.

    With ``distributed=True`` the same environment runs over the real system, every role a
    process (``iw_zenoh/DistributedScenario-v0``, :class:`~iw_zenoh.learn.distributed.DistributedEnv`,
    which also takes ``record=`` and ``log_dir=``); call ``close()`` to stop its processes."""
    return gym.make(DISTRIBUTED_ID if distributed else SCENARIO_ID, path=path, robot=robot, **kwargs)
