"""Re-simulating a recorded lock-step run reproduces it exactly; swapping an agent changes it; the
tick in one process (:class:`iw_zenoh.sim.local.LocalWorld`) gives its states and readings bit for bit."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import msgspec
import pytest

from iw_zenoh.convert import grid_from_msg, lab_from_msg
from iw_zenoh.messages import Hear, Say, SensorReading
from iw_zenoh.record.reader import RecordingReader
from iw_zenoh.record.resim import _make_agent, load_run, resimulate
from iw_zenoh.sim.local import LocalWorld
from tests.integration.harness import MAPS, iwz_run_argv

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(150)]

SCENARIO = """
name = "lockrec"
[world]
map = "{map}"
grid = "{grid}"
mode = "lockstep"
seed = 5
duration_s = 4
lockstep_timeout_ms = 60000  # a busy machine's laggard would make the run depend on it
[[agents]]
program = "wanderer"
args = ["--count", "1", "--seed", "3"]
robots = 1
[[agents]]  # answers in action batches (as hosts of many robots do): re-simulated all the same
program = "wanderer"
args = ["--count", "1", "--seed", "4", "--batch", "on"]
robots = 1
[[agents]]  # says its position on the radio each tick, sees with a 64-beam laser
program = "convoy"
args = ["--role", "leader", "--id", "4", "--waypoints", "34,9.5"]
spec = {{ lasers = [{{ id = 0, x_m = 0.5, angle_deg = 0, fov_deg = 270, beams = 64, range_m = 10 }}] }}
[[agents]]  # hears the leader
program = "convoy"
args = ["--role", "follower", "--id", "3", "--follow", "4"]
[[agents]]  # two chairs head-on along the corridor, pushing blindly: collisions
program = "probe"
args = ["--creep", "0.15"]
spec = {{ id = 5, x_m = 20.0, y_m = 9.5, dir_deg = 0.0 }}
[[agents]]  # with movement noise
program = "probe"
args = ["--creep", "0.15"]
spec = {{ id = 6, x_m = 22.0, y_m = 9.5, dir_deg = 180.0, noise = {{ motion = {{ std = 0.05 }} }} }}
"""


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("resim")
    sc = tmp / "lockrec.toml"
    sc.write_text(SCENARIO.format(map=MAPS / "hospital.xml", grid=MAPS / "hospital-grid.xml"))
    out = tmp / "lockrec.mcap"
    argv = iwz_run_argv(sc, tmp, "lr", record=out)
    r = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    return out


def test_resim_of_a_lockstep_recording_equals_it_bit_for_bit(recording: Path) -> None:
    with recording.open("rb") as f:
        run = load_run(f)
    assert len(run.states) == 40
    res = resimulate(run)
    assert res.ticks == 40
    assert res.diverged_at is None
    assert res.identical_until == 40


def test_swapping_an_agent_from_time_t_changes_only_what_follows(recording: Path) -> None:
    with recording.open("rb") as f:
        run = load_run(f)
    swap = _make_agent("1=waypoint --waypoints '2,2'")
    res = resimulate(run, swap=swap, from_ns=2_000_000_000)
    assert res.identical_until >= 20  # before T everything is as recorded
    assert res.diverged_at is not None
    assert res.diverged_at > 20


def test_resim_cli_reports_identical(recording: Path) -> None:
    r = subprocess.run(
        [sys.executable, "-m", "iw_zenoh.cli", "resim", str(recording)], capture_output=True, text=True, timeout=60
    )
    assert r.returncode == 0, r.stdout + r.stderr
    assert "every state identical" in r.stdout


def test_the_tick_in_one_process_gives_the_lockstep_runs_states_readings_and_radio_bit_for_bit(
    recording: Path,
) -> None:
    with recording.open("rb") as f:
        run = load_run(f)
    readings: dict[int, dict[int, SensorReading]] = {}
    heard: dict[int, dict[int, list[object]]] = {}
    said: dict[int, dict[int, str]] = {}
    with recording.open("rb") as f:
        for r in RecordingReader(f).records(("sensors", "hear", "say")):
            m = r.message
            if isinstance(m, SensorReading):
                readings.setdefault(m.tick, {})[m.robot_id] = msgspec.structs.replace(m, tick_wall_ns=0)
            elif isinstance(m, Hear):
                heard.setdefault(m.tick, {})[m.robot_id] = list(m.messages)
            elif isinstance(m, Say):
                said.setdefault(m.tick, {})[m.robot_id] = m.text
    info = run.info
    world = LocalWorld(
        lab_from_msg(info.lab),
        grid_from_msg(info.grid),
        seed=info.seed,
        profile=info.profile,
        period_ms=info.period_ns / 1e6,
        sim=info.sim,
    )
    for reply in run.specs:
        assert reply.spec is not None
        world.add(reply.spec)
    collisions = 0
    for n in range(1, max(run.states) + 1):
        # the agents' answers to tick n - 1's readings, and what they said, as the world took them
        step = world.step(run.actions.get(n - 1, {}), say=said.get(n - 1, {}))
        want = run.states[n]
        assert msgspec.structs.replace(step.state, tick_wall_ns=0) == msgspec.structs.replace(want, tick_wall_ns=0), n
        assert {k: msgspec.structs.replace(v, tick_wall_ns=0) for k, v in step.readings.items()} == readings[n], n
        assert step.heard == heard.get(n, {}), n
        collisions += sum(e.kind == "collision" for e in step.events)
    # what the comparison covered: a laser, noise, the radio and collisions
    assert any(r.lasers for r in readings[1].values())
    assert len(run.collisions) == collisions > 0
    assert sum(len(h) for h in heard.values()) > 0
