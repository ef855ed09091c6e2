"""``make_env(..., distributed=True)``: the scenario environment over the real system (every role a
process, lock-step) gives the in-process environment's observations, rewards and ends tick by
tick for the same seed and actions; ``close()`` stops every process it started."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import iw_zenoh.learn
from iw_zenoh.errors import IwError
from iw_zenoh.learn.distributed import DistributedEnv

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

# the learner drives robot 1 (a convoy leader's chair with a 32-beam laser) along a corridor; a
# follower hears its positions over the radio and follows it; a wanderer with movement noise moves
# about: readings, noise, the radio and another agent all enter the comparison
SCENARIO = """
name = "learnpair"
[world]
map = "lab.xml"
grid = "grid.xml"
mode = "lockstep"
seed = 2
duration_s = 30
[[agents]]
program = "convoy"
args = ["--role", "leader", "--id", "1", "--waypoints", "16,5"]
spec = {{ x_m = 6.0, y_m = 5.0, dir_deg = 0.0, lasers = [{{ id = 0, x_m = 0.5, angle_deg = 0, fov_deg = 270, beams = 32, range_m = 10 }}] }}
[[agents]]
program = "convoy"
args = ["--role", "follower", "--id", "2", "--follow", "1"]
spec = {{ x_m = 3.0, y_m = 5.0, dir_deg = 0.0 }}
[[agents]]
program = "wanderer"
args = ["--count", "1", "--seed", "3"]
spec = {{ id = 3, x_m = 10.0, y_m = 2.0, dir_deg = 90.0, noise = {{ motion = {{ std = 0.05 }} }} }}
"""
STEPS = 25


@pytest.fixture(scope="module")
def scenario(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("learnpair")
    (tmp / "lab.xml").write_text('<Lab Name="hall" Width="20" Height="10"/>')
    (tmp / "grid.xml").write_text('<Grid><Position X="3" Y="5" Dir="0"/></Grid>')
    path = tmp / "learnpair.toml"
    path.write_text(SCENARIO.format())
    return path


def _episode(env: object, seed: int) -> list[tuple[np.ndarray, float, bool, bool]]:
    obs, _ = env.reset(seed=seed)  # type: ignore[attr-defined]
    out = [(obs, 0.0, False, False)]
    g = np.random.default_rng(seed)
    for _ in range(STEPS):
        action = np.asarray([g.uniform(0.2, 1.0), g.uniform(-0.5, 0.5)], dtype=np.float32)
        obs, reward, terminated, truncated, _ = env.step(action)  # type: ignore[attr-defined]
        out.append((obs, reward, terminated, truncated))
        if terminated or truncated:
            break
    return out


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_the_same_seed_and_actions_give_the_same_trajectory_in_process_and_over_the_real_system(
    scenario: Path, tmp_path: Path
) -> None:
    local = iw_zenoh.learn.make_env(scenario, robot=1, goal=(16.0, 5.0))
    want = _episode(local, 7)
    env = iw_zenoh.learn.make_env(scenario, robot=1, goal=(16.0, 5.0), distributed=True, log_dir=tmp_path / "logs")
    try:
        got = _episode(env, 7)
        run = env.unwrapped
        assert isinstance(run, DistributedEnv)
        assert run.launcher is not None
        pids = [c.proc.pid for c in run.launcher.children if c.proc is not None]
        assert {c.role for c in run.launcher.children} >= {"router", "world", "collision", "sensors", "radio"}
    finally:
        env.close()
    assert len(got) == len(want) == STEPS + 1
    for n, ((o1, r1, t1, u1), (o2, r2, t2, u2)) in enumerate(zip(want, got, strict=True)):
        np.testing.assert_array_equal(o2, o1, err_msg=f"observation of step {n}")
        assert (r2, t2, u2) == (r1, t1, u1), n
    assert want[-1][0][-2:].any()  # the learner moved (its wheel speeds), the comparison is not of a chair standing
    assert pids
    assert not [p for p in pids if _alive(p)], "close() left processes running"


def test_a_robot_no_agent_asks_for_by_id_is_refused_with_its_reason(scenario: Path) -> None:
    with pytest.raises(IwError, match="no agent asks for robot 3 by id"):
        iw_zenoh.learn.make_env(scenario, robot=3, goal=(16.0, 5.0), distributed=True)
