"""``iwz report`` on a real lock-step run: a waypoint chair drives straight 7 m to its goal in an
empty hall; the scenario's goal reaches the report through the recording."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.integration.harness import iwz_run_argv

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(180)]

LAB = '<Lab Name="hall" Width="20" Height="10"/>'
SCENARIO = """
name = "straight"
[world]
map = "{map}"
mode = "lockstep"
seed = 3
duration_s = 60
[[agents]]
program = "waypoint"
args = ["--id", "1", "--start", "3,5,0", "--waypoints", "10,5"]
[criteria]
max_collisions = 0
stop_when_reached = true
[[criteria.reach]]
robot = 1
x_m = 10.0
y_m = 5.0
within_m = 0.5
"""
MAX_SPEED_MPS = 0.5  # the LIACC prototype's, which the waypoint agent drives


def test_the_report_of_a_straight_lockstep_drive(tmp_path: Path) -> None:
    (tmp_path / "hall.xml").write_text(LAB)
    sc = tmp_path / "straight.toml"
    sc.write_text(SCENARIO.format(map=tmp_path / "hall.xml"))
    out = tmp_path / "straight.mcap"
    r = subprocess.run(iwz_run_argv(sc, tmp_path, "rep", record=out), capture_output=True, text=True, timeout=150)
    assert r.returncode == 0, r.stdout + r.stderr
    rep = subprocess.run(
        [sys.executable, "-m", "iw_zenoh.cli", "report", str(out), "--json"], capture_output=True, text=True, timeout=60
    )
    assert rep.returncode == 0, rep.stdout + rep.stderr
    [run] = json.loads(rep.stdout)["runs"]
    [chair] = run["chairs"]
    assert chair["robot_id"] == 1
    # reached within 0.5 m of x = 10 from x = 3: at least 6.5 m straight, and not much more
    assert 6.5 <= chair["path_length_m"] <= 7.6
    assert chair["time_to_goal_s"] is not None  # the goal came from the scenario, through the recording
    assert chair["time_to_goal_s"] >= 6.5 / MAX_SPEED_MPS
    assert 0.0 < chair["peak_speed_mps"] <= MAX_SPEED_MPS * 1.01
    assert chair["collisions"] == 0
    assert chair["watchdog_stops"] == 0
    assert chair["min_clearance_people_m"] is None  # alone in the hall
    assert 2.0 < chair["min_clearance_walls_m"] < 5.0 - 0.33  # its back to the hall's end, at the start
    assert run["run"]["goals_reached"] == 1
