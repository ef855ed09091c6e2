"""``iwz agent policy``: a policy driving a chair in a lock-step ``iwz run`` gives the very
trajectory the in-process environment gives it (same observation, same action, same wheel powers),
and a policy that cannot be loaded is refused saying why."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

import iw_zenoh.learn
from iw_zenoh.errors import ConfigError
from iw_zenoh.learn.policy import load_policy
from iw_zenoh.learn.scenario import ScenarioEnv
from iw_zenoh.messages import WorldState
from iw_zenoh.record.reader import RecordingReader
from tests.integration.harness import iwz_run_argv

# steers towards the goal from the observation's last seven values (compass, goal, wheels), and
# slows when a sonar reads near: every part of the observation matters to the action
POLICY = """
import numpy as np

def steer(obs):
    dist, s, c = obs[-5], obs[-4], obs[-3]
    near = float(np.min(obs[:8]))
    return np.array([min(1.0, dist) * (0.3 if near < 0.6 else 1.0) * max(c, 0.0), float(np.arctan2(s, c))])
"""
SCENARIO = """
name = "pol"
[world]
map = "lab.xml"
mode = "lockstep"
seed = 3
duration_s = 2.5
[[agents]]
program = "policy"
args = ["--policy", "./steer.py:steer", "--goal", "12,7", "--id", "1", "--start", "3,4,20"]
[[agents]]
program = "wanderer"
args = ["--count", "1", "--seed", "5"]
spec = { id = 2, x_m = 8.0, y_m = 2.0, dir_deg = 90.0 }
[[criteria.reach]]
robot = 1
x_m = 12.0
y_m = 7.0
"""


def _robots(st: WorldState) -> dict[int, tuple[object, ...]]:
    """Each robot's pose, flags and motion in a state."""
    f = ("x", "y", "heading", "collided", "rolled_left", "rolled_right", "speed")
    return {rid: tuple(getattr(st, k)[i] for k in f) for i, rid in enumerate(st.ids)}


@pytest.fixture
def scenario(tmp_path: Path) -> Path:
    (tmp_path / "lab.xml").write_text('<Lab Name="hall" Width="20" Height="10"/>')
    (tmp_path / "steer.py").write_text(POLICY)
    path = tmp_path / "pol.toml"
    path.write_text(SCENARIO)
    return path


@pytest.mark.zenoh
@pytest.mark.timeout(180)
def test_a_policy_in_a_lockstep_run_drives_as_in_the_in_process_environment(scenario: Path, tmp_path: Path) -> None:
    out = tmp_path / "pol.mcap"
    r = subprocess.run(iwz_run_argv(scenario, tmp_path, "pol", record=out), capture_output=True, text=True, timeout=150)
    assert r.returncode in (0, 1), r.stdout + r.stderr
    recorded: dict[int, WorldState] = {}
    with out.open("rb") as f:
        for rec in RecordingReader(f).records(("state",)):
            if isinstance(rec.message, WorldState):
                recorded[rec.message.tick] = rec.message
    policy = load_policy(f"{scenario.parent / 'steer.py'}:steer")
    env = iw_zenoh.learn.make_env(scenario, robot=1, goal=(12.0, 7.0))
    inner = env.unwrapped
    assert isinstance(inner, ScenarioEnv)
    obs, _ = env.reset(seed=3)
    assert inner.episode is not None
    states = [inner.episode.last.state]
    for _ in range(24):
        obs, *_ = env.step(np.asarray(policy(obs), dtype=np.float32))
        states.append(inner.episode.last.state)
    assert len(recorded) >= 25
    for st in states:  # robot by robot (the arrays are in the order the robots registered)
        assert _robots(st) == _robots(recorded[st.tick]), st.tick
    assert states[-1].x[states[-1].ids.index(1)] > 3.3  # the policy drove it


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("steer", "MODULE:NAME"),
        ("no_such_module_here:f", "could not be imported"),
        ("./missing.py:f", "no such file"),
        ("math:nosuch", "has no 'nosuch'"),
        ("math:pi", "float: give a function"),
    ],
)
def test_a_policy_that_cannot_be_loaded_is_refused_saying_why(text: str, why: str) -> None:
    with pytest.raises(ConfigError, match="--policy") as e:
        load_policy(text)
    assert why in str(e.value)
