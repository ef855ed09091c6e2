"""Re-simulating a recorded lock-step run reproduces it exactly; swapping an agent changes it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from iw_zenoh.record.resim import _make_agent, load_run, resimulate
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
[[agents]]
program = "wanderer"
args = ["--count", "1", "--seed", "3"]
robots = 1
[[agents]]  # answers in action batches (as hosts of many robots do): re-simulated all the same
program = "wanderer"
args = ["--count", "1", "--seed", "4", "--batch", "on"]
robots = 1
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
