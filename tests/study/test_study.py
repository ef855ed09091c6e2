"""``iwz study`` on real lock-step runs: five seeds give the rows five separate ``iwz run --seed N``
and ``iwz report`` give; a run that fails or outlives its timeout is a row with its reason and the
study still finishes; a refused field is refused before anything runs."""

from __future__ import annotations

import json
import re
import socket
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from iw_zenoh.study.runs import Condition, RunJob, run_one
from tests.integration.harness import iwz_run_argv

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(300)]

# a waypoint chair (noisy GPS: each seed drives a little differently) with a wanderer beside it
SCENARIO = """
name = "tiny"
[world]
map = "lab.xml"
mode = "lockstep"
seed = 0
duration_s = 1.5
[[agents]]
program = "waypoint"
args = ["--id", "1", "--start", "3,5,0", "--waypoints", "10,5"]
[[agents]]
program = "wanderer"
args = ["--count", "1", "--seed", "4"]
spec = { id = 2, x_m = 6.0, y_m = 2.0, dir_deg = 90.0 }
[criteria]
max_collisions = 0
[[criteria.reach]]
robot = 1
x_m = 10.0
y_m = 5.0
"""
IWZ = [sys.executable, "-m", "iw_zenoh.cli"]


@pytest.fixture(scope="module")
def scenario(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("study")
    (tmp / "lab.xml").write_text('<Lab Name="hall" Width="20" Height="10"/>')
    path = tmp / "tiny.toml"
    path.write_text(SCENARIO)
    return path


def _run_and_report(scenario: Path, tmp: Path, seed: int) -> dict[str, object]:
    """``iwz run SCENARIO --lockstep --seed N`` then ``iwz report --json``: the run's object."""
    out = tmp / f"alone-{seed}.mcap"
    argv = iwz_run_argv(
        scenario, tmp / f"alone-{seed}", f"alone{seed}", record=out, extra=("--lockstep", "--seed", str(seed))
    )
    r = subprocess.run(argv, capture_output=True, text=True, timeout=150)
    assert r.returncode in (0, 1), r.stdout + r.stderr
    rep = subprocess.run([*IWZ, "report", str(out), "--json"], capture_output=True, text=True, timeout=60)
    assert rep.returncode == 0, rep.stderr
    run: dict[str, object] = json.loads(rep.stdout)["runs"][0]
    del run["file"]
    return run


def test_a_study_of_five_seeds_gives_the_rows_of_five_separate_runs_and_reports(scenario: Path, tmp_path: Path) -> None:
    out = tmp_path / "st"
    study = subprocess.Popen(
        [*IWZ, "study", str(scenario), "--seeds", "1-5", "--jobs", "2", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        with ThreadPoolExecutor(2) as pool:  # meanwhile, the same five runs one by one, two at a time
            alone = dict(
                zip(range(1, 6), pool.map(lambda s: _run_and_report(scenario, tmp_path, s), range(1, 6)), strict=True)
            )
        _, err = study.communicate(timeout=240)
    finally:
        if study.poll() is None:
            study.kill()
            study.wait()
    assert study.returncode == 0, err
    assert "5/5" in err  # progress on stderr
    got = json.loads((out / "study.json").read_text())
    rows = {r["seed"]: r for r in got["runs"]}
    assert sorted(rows) == [1, 2, 3, 4, 5]
    for seed, row in rows.items():
        assert row["status"] == "ok", row
        assert row["report"] == alone[seed], seed
    paths = {json.dumps(r["report"]["chairs"][0]["path_length_m"]) for r in rows.values()}
    assert len(paths) > 1  # the seeds differ: the comparison is of five different runs
    s = got["summary"]["base"]
    assert s["runs"] == 5
    assert s["failed"] == 0
    lengths = [r["report"]["run"]["path_length_m"] for r in rows.values()]
    pl = s["run"]["path_length_m"]
    assert pl["n"] == 5
    assert pl["mean"] == pytest.approx(sum(lengths) / 5)
    assert pl["ci95"][0] < pl["mean"] < pl["ci95"][1]
    page = (out / "study.html").read_text()
    assert "<svg" in page
    assert not re.search(r"""(src|href)=["']?(https?:|//)""", page)  # self-contained: nothing fetched


def test_a_failed_run_is_a_row_with_its_reason_and_the_study_finishes(scenario: Path, tmp_path: Path) -> None:
    out = tmp_path / "st"
    r = subprocess.run(
        [
            *IWZ,
            "study",
            str(scenario),
            "--seeds",
            "1",
            "--jobs",
            "2",
            "--out",
            str(out),
            "--condition",
            "fine",
            "--condition",
            "broken",
            "--set",
            'agents[1].program="nosuch"',
        ],
        capture_output=True,
        text=True,
        timeout=200,
    )
    assert r.returncode == 1, r.stderr  # some run failed; the study is written all the same
    got = json.loads((out / "study.json").read_text())
    rows = {row["condition"]: row for row in got["runs"]}
    assert rows["fine"]["status"] == "ok", rows["fine"]["reason"]
    assert rows["broken"]["status"] == "failed"
    assert "nosuch" in rows["broken"]["reason"]
    assert got["summary"]["broken"] == {**got["summary"]["broken"], "runs": 0, "failed": 1}
    assert "FAILED" in r.stderr
    assert "nosuch" in (out / "study.html").read_text()


def test_a_run_past_its_timeout_is_stopped_and_failed_with_the_reason(scenario: Path, tmp_path: Path) -> None:
    job = RunJob(scenario, Condition("slow"), 1, tmp_path / "runs", timeout_s=0.5)
    row = run_one(job)
    assert row["status"] == "failed"
    assert "timed out after 0.5 s" in row["reason"]
    assert row["exit_code"] is None


def test_a_field_the_scenario_refuses_ends_the_study_before_any_run(scenario: Path, tmp_path: Path) -> None:
    r = subprocess.run(
        [*IWZ, "study", str(scenario), "--seeds", "1-3", "--out", str(tmp_path / "st"), "--set", "world.nosuch=1"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2
    assert "world.nosuch" in r.stderr
    assert "unknown field" in r.stderr
    assert not (tmp_path / "st").exists()


def test_a_run_whose_routers_port_was_taken_meanwhile_starts_again_on_another(
    scenario: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The port a run is given can be taken before its router binds it (by any connection's own
    port: the kernel hands those out of the same range); that run never ran: it is started again."""
    from iw_zenoh.bus.net import free_port
    from iw_zenoh.study import runs

    with socket.socket() as held:  # bound, not listening: as an outgoing connection holds its port
        held.bind(("127.0.0.1", 0))
        taken = held.getsockname()[1]
        given = iter([taken])
        monkeypatch.setattr(runs, "free_port", lambda: next(given, None) or free_port())
        row = run_one(RunJob(scenario, Condition("base"), 1, tmp_path / "base", timeout_s=150))
    assert row["status"] == "ok", row["reason"]
    assert f"--port {taken} " not in row["command"]
    assert row["command"].startswith("iwz run ")
