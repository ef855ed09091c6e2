"""The world process warms its compiled propose and commit up before it joins (issue #36): after
``iw_zenoh.nodes.world.warm_up``, ticks of either profile, with movement noise, a Real robot's
report and a tick held without a verdict, compile nothing more (a compilation in a real-time
tick would make it late). Run in a fresh interpreter, so nothing compiled before counts."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

TICKS = """
import json
from numba.core.registry import CPUDispatcher
from iw_zenoh.core import drive
from iw_zenoh.nodes import world

def compiled():
    return {n: len(o.signatures) for n, o in vars(drive).items() if isinstance(o, CPUDispatcher)}

untouched = compiled()
world.warm_up()
warm = compiled()

from iw_zenoh.messages import NoiseMsg, PoseReport, RegisterRequest, RobotSpecMsg, SensorNoiseMsg
from tests.support.sim_core import step, world_core

moved = {}
for profile in ("native", "ciberrato"):
    core = world_core(profile=profile, motors_noise_pct=2.0, expect=0)
    noisy = SensorNoiseMsg(motion=NoiseMsg(mean=0.01, std=0.05))
    core.register(RegisterRequest(spec=RobotSpecMsg(name="s", noise=noisy), agent="a"), 0)
    core.register(RegisterRequest(spec=RobotSpecMsg(name="r", type="Real"), agent="b"), 0)
    for n in range(1, 4):
        core.on_pose_report(PoseReport(tick=n, robot_id=2, x=5.0 + 0.1 * n, y=5.0, dir_deg=0.0), 0)
        step(core, n * 100_000_000, verdict=n != 2)
    moved[profile] = core.state.pose.tolist()
print(json.dumps({"untouched": untouched, "warm": warm, "after": compiled(), "moved": moved}))
"""


def test_the_worlds_warm_up_compiles_every_kernel_its_ticks_run(tmp_path: Path) -> None:
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(root)}
    done = subprocess.run(
        [sys.executable, "-c", TICKS], env=env, cwd=root, capture_output=True, text=True, timeout=240, check=False
    )
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert set(out["untouched"].values()) == {0}
    assert out["warm"]["propose_into"] == out["warm"]["commit_into"] == 1
    assert out["after"] == out["warm"]  # the ticks compiled nothing
    for pose in out["moved"].values():  # they did step: the Real robot is where it said
        assert pose[1][:2] == [5.3, 5.0]
