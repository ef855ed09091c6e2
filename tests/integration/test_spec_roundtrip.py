"""Every field of a robot's spec, given in a scenario, is what the world accepts; a bad one is
refused with its path before anything starts (``iwz run``, real processes, the recording read)."""

from __future__ import annotations

import math
import subprocess
import tomllib
from pathlib import Path
from typing import Any

import msgspec
import pytest
from mcap.reader import make_reader

from iw_zenoh import keys
from iw_zenoh.messages import IrSensorMsg, LaserMsg, NoiseMsg, RobotSpecMsg, SensorNoiseMsg, WorldInfo, decode
from tests.integration.harness import MAPS, iwz_run_argv, stop_run

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(300)]

# every field of the registration, none at its default
SPEC = """
[agents.spec]
name = "given"
id = 7
type = "Simulated"
shape = "rect"
width_m = 0.9
height_m = 0.6
com = 0.7
x_m = 3.0
y_m = 2.5
dir_deg = 30.0
max_speed_mps = 0.7
acceleration_curve = 0.3
ticks_per_m = 1500.0
legacy = true
beacon_height_m = 0.8
ir_sensors = [
    { id = 0, x_m = 0.6, y_m = 0.1, angle_deg = 10.0, cone_deg = 20.0, range_m = 2.5 },
    { id = 5, x_m = -0.2, y_m = -0.3, angle_deg = -170.0, cone_deg = 45.0, range_m = 1.5 },
]
bumpers = [{ id = 2, corners = [[0.6, -0.3], [0.65, -0.3], [0.65, 0.3], [0.6, 0.3]] }]
lasers = [{ id = 1, x_m = 0.5, y_m = 0.05, angle_deg = 5.0, fov_deg = 180.0, beams = 33, range_m = 6.0 }]

[agents.spec.noise]
proximity_m = { mean = 0.01, std = 0.02, enabled = true }
proximity_legacy = { mean = 0.0, std = 0.2, enabled = false }
compass_deg = { mean = 0.5, std = 1.0, enabled = true }
beacon_deg = { mean = 0.0, std = 3.0, enabled = false }
gps_m = { mean = 0.0, std = 0.05, enabled = true }
gps_heading_deg = { mean = 0.0, std = 1.5, enabled = true }
encoder_slip = { mean = 0.0, std = 0.01, enabled = false }
motion = { mean = 0.0, std = 0.03, enabled = true }
laser_m = { mean = 0.0, std = 0.02, enabled = true }
"""

SCENARIO = """
[world]
map = "{map}"
mode = "lockstep"
duration_s = 2

[[agents]]
program = "waypoint"
args = ["--waypoints", "4,2.5", "--id", "1", "--start", "2,2,0"]
{spec}
"""


def _iwz_run(scenario: Path, tmp: Path, record: Path | None) -> subprocess.CompletedProcess[str]:
    argv = iwz_run_argv(scenario, tmp / "logs", "spec", record=record)
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = p.communicate(timeout=200)
    except subprocess.TimeoutExpired:
        out, err = stop_run(p)
        pytest.fail(f"still running after 200 s, stopped:\n{out}{err}")
    return subprocess.CompletedProcess(argv, p.returncode, out, err)


def _same(given: Any, accepted: Any, at: str) -> None:
    if isinstance(given, dict):
        for k, v in given.items():
            _same(v, accepted[k], f"{at}.{k}")
    elif isinstance(given, list):
        assert len(given) == len(accepted), at
        for i, (g, a) in enumerate(zip(given, accepted, strict=True)):
            _same(g, a, f"{at}[{i}]")
    elif isinstance(given, float):
        assert math.isclose(given, accepted, abs_tol=1e-9), f"{at}: gave {given}, the world accepted {accepted}"
    else:
        assert given == accepted, f"{at}: gave {given!r}, the world accepted {accepted!r}"


def test_every_spec_field_from_a_scenario_is_the_worlds_accepted_spec(tmp_path: Path) -> None:
    given = tomllib.loads(SPEC)["agents"]["spec"]
    assert set(given) == set(RobotSpecMsg.__struct_fields__), "give every field of the registration"
    assert set(given["noise"]) == set(SensorNoiseMsg.__struct_fields__)
    assert all(set(n) == set(NoiseMsg.__struct_fields__) for n in given["noise"].values())
    assert all(set(s) == set(IrSensorMsg.__struct_fields__) for s in given["ir_sensors"])
    assert all(set(s) == set(LaserMsg.__struct_fields__) for s in given["lasers"])
    defaults = msgspec.to_builtins(RobotSpecMsg(name="x"))
    assert all(given[f] != defaults[f] for f in ("width_m", "height_m", "com", "max_speed_mps", "acceleration_curve"))
    scenario = tmp_path / "spec.toml"
    scenario.write_text(SCENARIO.format(map=MAPS / "open-room.xml", spec=SPEC))
    rec = tmp_path / "run.mcap"
    r = _iwz_run(scenario, tmp_path, rec)
    assert r.returncode == 0, r.stdout + r.stderr
    accepted = None
    with rec.open("rb") as f:
        for _, _, m in make_reader(f).iter_messages(topics=[keys.info("spec")]):
            robots = decode(m.data, WorldInfo).robots
            accepted = next((s for s in robots if s.name == "given"), accepted)
    assert accepted is not None, "the world never listed the robot"
    _same(given, msgspec.to_builtins(accepted), "spec")


def test_a_bad_spec_in_a_scenario_is_refused_with_its_path_before_anything_starts(tmp_path: Path) -> None:
    bad = SPEC.replace("range_m = 1.5", "range_m = 0.0")
    scenario = tmp_path / "bad.toml"
    scenario.write_text(SCENARIO.format(map=MAPS / "open-room.xml", spec=bad))
    r = _iwz_run(scenario, tmp_path, None)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"iwz run: {scenario}: agents[0].spec.ir_sensors[1].range_m: must be > 0, got 0.0" in r.stdout + r.stderr
