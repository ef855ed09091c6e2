"""A learned policy as an agent of the distributed system: ``iwz agent policy --policy
MODULE:NAME --goal X,Y`` (so ``iwz run`` and ``iwz study`` evaluate what was trained in-process).

Each tick the agent builds the very observation the learning environments give
(:class:`~iw_zenoh.learn.nav.Senses`: its readings, the committed state's pose and wheel speeds,
the goal), asks the policy for an action in ``[-1, 1]^2`` and turns it into wheel powers through
its spec (:func:`~iw_zenoh.learn.nav.to_powers`). The agent host hands it the world's state of
the tick before its readings (``on_state``), so nothing differs from ``ChairNav-v0`` or
:func:`~iw_zenoh.learn.make_env`.

The policy (``--policy``) is ``MODULE:NAME`` (an importable module) or ``./file.py:NAME``; NAME is
either a function ``obs -> action`` or an object with Stable-Baselines3's
``predict(obs, deterministic=True) -> (action, state)`` (a loaded model).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from iw_zenoh.agent.hosting import Command
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.errors import ConfigError
from iw_zenoh.learn.nav import ACTIONS, Goal, Senses, to_powers
from iw_zenoh.messages import Heard, SensorReading, WorldState

__all__ = ["Policy", "PolicyAgent", "load_policy"]

Policy = Callable[[np.ndarray], Any]  # an observation in, an action in [-1, 1]^2 out


def _module(target: str) -> Any:
    """The module ``target`` names: a ``.py`` file's path, or a module's dotted name."""
    if target.endswith(".py"):
        path = Path(target)
        if not path.is_file():
            raise ConfigError("--policy", f"{target}: no such file ({path.resolve()})")
        name = f"iwz_policy_{path.stem}".replace("-", "_")
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise ConfigError("--policy", f"{target}: not a Python file Python can import")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        sys.path.insert(0, str(path.resolve().parent))  # its own helpers beside it
        spec.loader.exec_module(module)
        return module
    return importlib.import_module(target)


def load_policy(text: str) -> Policy:
    """The policy ``MODULE:NAME`` or ``./file.py:NAME`` names, as a function ``obs -> action``.

    Raises:
        ConfigError: The form is wrong, the module or name is missing, or it is not callable
            (saying which, and the form).
    """
    target, sep, name = text.rpartition(":")
    if not sep or not target or not name:
        raise ConfigError("--policy", f"takes MODULE:NAME or ./file.py:NAME, got {text!r}")
    try:
        module = _module(target)
    except ConfigError:
        raise
    except Exception as e:  # the user's module failed to import: say which and why
        raise ConfigError("--policy", f"{target} could not be imported: {type(e).__name__}: {e}") from None
    obj = getattr(module, name, None)
    if obj is None:
        raise ConfigError("--policy", f"{target} has no {name!r}")
    predict = getattr(obj, "predict", None)
    if callable(predict):  # a Stable-Baselines3 model: its deterministic action
        return lambda obs: predict(obs, deterministic=True)[0]
    if not callable(obj):
        raise ConfigError("--policy", f"{text} is a {type(obj).__name__}: give a function obs -> action or a model")
    return obj  # type: ignore[no-any-return]


class PolicyAgent:
    """A chair driven by a policy from the learning environments' observation.

    Args:
        spec: The chair to register.
        policy: ``obs -> action``.
        goal: Where it goes (the observation's goal).
        action: ``"vw"`` or ``"wheels"``, as the policy was trained.

    The tick's period (the observation's wheel speeds are distances over it) is the world's:
    a state's simulated time over its tick.
    """

    def __init__(self, spec: RobotSpec, policy: Policy, goal: Goal, *, action: str = "vw") -> None:
        if action not in ACTIONS:
            raise ConfigError("--action", f"must be one of {ACTIONS}, got {action!r}")
        self._spec = spec
        self.policy = policy
        self.goal = goal
        self.action = action
        self.senses: Senses | None = None
        self.robot_id = 0
        self.state: WorldState | None = None

    def spec(self) -> RobotSpec:
        """The robot to register."""
        return self._spec

    def on_registered(self, robot_id: int, spec: RobotSpec) -> None:
        """Takes the id and the spec the world accepted (the observation is laid out from it)."""
        self.robot_id, self._spec = robot_id, spec

    def on_state(self, state: WorldState) -> None:
        """Keeps the tick's committed state (the pose and wheel speeds the observation holds)."""
        self.state = state
        if self.senses is None and state.tick > 0:  # the world's period: tick n is at n periods
            self.senses = Senses(self._spec, state.sim_time_ns / state.tick / 1e9)

    def observe(self, reading: SensorReading) -> np.ndarray | None:
        """The observation of this tick, or None while the world's state does not hold the chair."""
        st = self.state
        if self.senses is None or st is None or self.robot_id not in st.ids:
            return None
        return self.senses.observe(reading, st, st.ids.index(self.robot_id), self.goal)

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """The policy's action for this tick's observation, as wheel powers (standing still until
        the first state with the chair has come)."""
        obs = self.observe(reading)
        if obs is None:
            return Command(0.0, 0.0)
        left, right = to_powers(np.asarray(self.policy(obs)), self._spec, self.action)
        return Command(left, right)
