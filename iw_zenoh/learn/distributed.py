"""A scenario as a Gymnasium environment over the real system: ``make_env(SCENARIO, robot=N,
distributed=True)``.

Each ``reset(seed=s)`` starts the scenario as ``iwz run`` starts it, in lock-step (a router, the
world, collision, sensors, radio and every other agent, each its own process, on a free loopback
port), with world seed ``s``, less the learner's robot's agent: this process registers that robot
itself, over Zenoh, as an agent does, and answers each tick's readings with the learner's action.
So a policy trained in-process (:class:`~iw_zenoh.learn.scenario.ScenarioEnv`) is evaluated on
the distributed system, and the same seed and actions give the same observations in both.
``close()`` (and the next ``reset``) stops every process the run started, by pid.

The world waits for the learner's action as long as it takes (its lock-step timeout is an hour),
so a slow learner changes how long an episode takes, never what happens in it. The learner's robot
must be one its scenario agent asks for by id (``--id N``) and that agent must drive it alone.
"""

from __future__ import annotations

import contextlib
import queue
import tempfile
import threading
from pathlib import Path
from typing import Any

import gymnasium as gym
import msgspec
import numpy as np

from iw_zenoh.agent import AgentHost
from iw_zenoh.agent.hosting import Command
from iw_zenoh.bus import ZenohBus
from iw_zenoh.bus.net import NetConfig, free_port
from iw_zenoh.core.modes import Mode
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.errors import IwError
from iw_zenoh.launch.launcher import Launcher
from iw_zenoh.launch.secure_run import asked_id
from iw_zenoh.learn.nav import Reward, Senses, goal_distance, to_powers
from iw_zenoh.learn.render import frame
from iw_zenoh.learn.scenario import ScenarioEnv, build
from iw_zenoh.maps import load_lab
from iw_zenoh.messages import Heard, SensorReading, WorldState
from iw_zenoh.scenario.tables import Scenario

__all__ = ["DistributedEnv"]

LEARNER = "learner"  # the agent name this process registers the learner's robot under
PATIENCE_MS = 3_600_000  # the world's lock-step timeout: how long it waits for the learner's action
TICK_WAIT_S = 120.0  # a tick's readings not here after this long: the run is broken


class _Learner:
    """The learner's robot as an agent: each tick's reading and state handed to the environment,
    its command taken from it (the host's thread waits for it)."""

    def __init__(self, spec: RobotSpec) -> None:
        self._spec = spec
        self.state: WorldState | None = None
        self.seen: queue.Queue[tuple[SensorReading, WorldState]] = queue.Queue()
        self.commands: queue.Queue[Command | None] = queue.Queue()

    def spec(self) -> RobotSpec:
        return self._spec

    def on_state(self, state: WorldState) -> None:
        self.state = state

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        assert self.state is not None  # the host waits for the tick's state before answering
        self.seen.put((reading, self.state))
        return self.commands.get() or Command(0.0, 0.0)  # None: closing, stand still


def _learner_entry(sc: Scenario, robot: int) -> int:
    """The index of the agent entry that drives ``robot`` alone (asking for it by id)."""
    for i, a in enumerate(sc.agents):
        if asked_id(a.argv) == robot:
            if a.robots != 1:
                raise IwError(f"{sc.name}: agents[{i}] drives {a.robots} robots; the learner's must drive it alone")
            return i
    raise IwError(f"{sc.name}: no agent asks for robot {robot} by id (--id {robot}); distributed=True needs one")


class DistributedEnv(ScenarioEnv):
    """A scenario over the distributed system (see the module doc).

    Arguments as :class:`~iw_zenoh.learn.scenario.ScenarioEnv`'s, and:

    Args:
        record: Record each episode's run to this MCAP file (None: not recorded).
        log_dir: Where the run's processes log (default: a new temporary folder).
    """

    def __init__(
        self,
        path: str | Path,
        robot: int,
        *,
        record: str | Path | None = None,
        log_dir: str | Path | None = None,
        **kw: Any,
    ) -> None:
        super().__init__(path, robot, **kw)
        self.entry = _learner_entry(self.scenario, robot)
        world, agents = build(self.scenario, self.scenario.world.seed)
        self.asked = agents[robot].spec()  # what its own agent would register
        self.specs = {rid: world.spec(rid) for rid in world.ids}
        self.senses = Senses(world.spec(robot), world.cfg.period_ms / 1000.0)
        self.max_steps = world.cfg.duration_ticks
        self.record = Path(record) if record is not None else None
        self.log_dir = Path(log_dir) if log_dir is not None else None
        self.launcher: Launcher | None = None
        self.bus: ZenohBus | None = None
        self.host: AgentHost | None = None
        self.learner: _Learner | None = None
        self._thread: threading.Thread | None = None
        self.state: WorldState | None = None
        self.steps = 0
        self._dist = 0.0

    def _scenario(self, seed: int) -> Scenario:
        """The scenario this process runs: the seed, lock-step, the learner's agent left out (but
        its robot awaited), and the world waiting for the learner as long as it takes."""
        sc = self.scenario
        world = msgspec.structs.replace(
            sc.world, seed=seed, mode=Mode.LOCKSTEP, expect=sc.robots, lockstep_timeout_ms=float(PATIENCE_MS)
        )
        agents = tuple(a for i, a in enumerate(sc.agents) if i != self.entry)
        return msgspec.structs.replace(sc, world=world, agents=agents)

    def _start(self, seed: int) -> None:
        """Starts the run and registers the learner's robot; its host answers on a thread of its own."""
        log_dir = self.log_dir or Path(tempfile.mkdtemp(prefix=f"iwz-learn-{self.scenario.name}-"))
        self.launcher = Launcher(
            self._scenario(seed), port=free_port(), sim="learn", log_dir=log_dir, status=False, record=self.record
        )
        self.launcher.start()
        if self.launcher.failed is not None:
            raise IwError(f"{self.launcher.failed.name} could not start: {self.launcher.failed.error()} ({log_dir})")
        if self.launcher.bus is not None:  # nothing supervises: its own session is not needed
            self.launcher.bus.close()
            self.launcher.bus = None
        self.bus = ZenohBus(NetConfig(connect=(self.launcher.endpoint,)))
        self.host = AgentHost(self.bus, "learn", LEARNER)
        self.learner = _Learner(self.asked)
        rid = self.host.add(self.learner, timeout_s=60.0)
        if rid != self.robot:
            raise IwError(f"the world gave the learner robot {rid}, not {self.robot}")
        host = self.host
        self._thread = threading.Thread(target=self._answer, args=(host,), name="learner-host", daemon=True)
        self._thread.start()

    @staticmethod
    def _answer(host: AgentHost) -> None:
        while not host.io.stop.is_set():
            host.step(0.2)

    def _next(self) -> tuple[SensorReading, WorldState]:
        assert self.learner is not None
        try:
            return self.learner.seen.get(timeout=TICK_WAIT_S)
        except queue.Empty:
            where = self.launcher.log_dir if self.launcher is not None else "?"
            raise IwError(
                f"no readings for the learner's robot within {TICK_WAIT_S:g} s; the run's logs: {where}"
            ) from None

    def _observe(self, reading: SensorReading, state: WorldState) -> np.ndarray:
        self.state = state
        return self.senses.observe(reading, state, state.ids.index(self.robot), self.goal)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Stops the last run and starts the scenario again, its world seeded by ``seed``
        (default the scenario's); the learner's first observation (tick 1)."""
        super(ScenarioEnv, self).reset(seed=seed)
        self.close()
        self._start(self.scenario.world.seed if seed is None else seed)
        obs = self._observe(*self._next())
        assert self.state is not None
        self.steps = 0
        self._dist = goal_distance(self.state, self.state.ids.index(self.robot), self.goal)
        return obs, {"goal": (self.goal.x, self.goal.y)}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One tick with the learner's action, over the bus; the same outcome as in-process."""
        if self.learner is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        left, right = to_powers(action, self.asked, self.action_mode)
        self.learner.commands.put(Command(left, right))
        reading, state = self._next()
        obs = self._observe(reading, state)
        self.steps += 1
        return (obs, *self._outcome(reading, state))

    def _outcome(self, reading: SensorReading, state: WorldState) -> tuple[float, bool, bool, dict[str, Any]]:
        """Reward, terminated, truncated and info, as :class:`~iw_zenoh.learn.episode.Episode` gives them."""
        terms, goal = self.reward_terms or Reward(), self.goal
        dist = goal_distance(state, state.ids.index(self.robot), goal)
        reached, collided = dist < goal.within, bool(reading.collision)
        r = terms.progress * (self._dist - dist) + terms.time
        r += terms.goal if reached else 0.0
        r += terms.collision if collided else 0.0
        self._dist = dist
        info = {"distance": dist, "reached": reached, "collided": collided, "tick": state.tick}
        truncated = self.steps >= self.max_steps or (bool(self.max_steps) and state.tick >= self.max_steps)
        return float(r), reached or collided, truncated, info

    def render(self) -> np.ndarray | None:
        """The picture of the last state (``rgb_array``), or None."""
        if self.render_mode is None or self.state is None:
            return None
        return frame(load_lab(self.scenario.world.map), self.state, self.specs, {self.robot: self.goal})

    def close(self) -> None:
        """Stops the run: the learner's host, its session, and every process the run started (by pid)."""
        if self.host is not None:
            self.host.io.stop.set()
        if self.learner is not None:
            self.learner.commands.put(None)  # a host waiting for an action stands the chair still
        if self._thread is not None:
            self._thread.join(10)
        if self.bus is not None:
            with contextlib.suppress(Exception):
                self.bus.close()
        if self.launcher is not None:
            self.launcher.shutdown()
        self.launcher = self.bus = self.host = self.learner = self._thread = None
        super().close()
