"""``iwz run`` judges its criteria on every state the world commits, not on the newest one when it
looks (every 0.1 s: in lock-step, many ticks apart). Before, a goal was reported reached at the
tick the launcher happened to look, so two lock-step runs of the same seed, whose states were
the same bit for bit, reported different times (revolving-door: robot 5 at t=102.7 s and
102.0 s), and a door that closed between two looks was judged never to have closed."""

from __future__ import annotations

import math
import re
import subprocess
from pathlib import Path

import pytest

from iw_zenoh.messages import WorldState
from iw_zenoh.record.reader import RecordingReader
from tests.integration.harness import iwz_run_argv, scenario_in, stop_run

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

GOAL = (9.0, 5.0, 0.5)
SCENARIO = f"""
name = "judged"
[world]
map = "lab.xml"
grid = "grid.xml"
mode = "lockstep"
duration_s = 60
[[agents]]
program = "waypoint"
args = ["--id", "1", "--waypoints", "{GOAL[0]},{GOAL[1]};17,5"]
[criteria]
[[criteria.reach]]
robot = 1
x_m = {GOAL[0]}
y_m = {GOAL[1]}
within_m = {GOAL[2]}
"""


def test_a_goal_is_reported_reached_at_the_first_committed_state_within_it(tmp_path: Path) -> None:
    scenario_in(tmp_path, "judged", SCENARIO)
    record = tmp_path / "run.mcap"
    p = subprocess.Popen(
        iwz_run_argv(tmp_path / "judged.toml", tmp_path / "logs", "judged", record=record),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        out, _ = p.communicate(timeout=180)
    finally:
        if p.poll() is None:
            stop_run(p)
    assert p.returncode == 0, out
    said = re.search(r"PASS robot 1 within 0\.5 m of \(9, 5\) at t=([0-9.]+) s", out)
    assert said is not None, out
    first = None
    with record.open("rb") as f:
        for r in RecordingReader(f).records(["state"]):
            st = r.message
            if isinstance(st, WorldState) and 1 in st.ids:
                i = st.ids.index(1)
                if math.hypot(st.x[i] - GOAL[0], st.y[i] - GOAL[1]) <= GOAL[2]:
                    first = st.sim_time_ns / 1e9
                    break
    assert first is not None
    assert said.group(1) == f"{first:.1f}", f"reported at t={said.group(1)} s, first within the goal at t={first} s"
