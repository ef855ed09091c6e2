"""Every role survives its own death during an ``iwz run``: killed, it comes back and the run goes
on to meet its criteria (a killed recorder goes on in the next part of the recording); an agent
stopped past the grace period drives again once resumed."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from iw_zenoh.messages import WorldState
from iw_zenoh.record.reader import RecordingReader
from tests.integration.faults import FaultRun as _Run
from tests.integration.faults import fault_scenario as _scenario
from tests.integration.faults import position_of as _at
from tests.integration.harness import ROOT, wait_event, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(170)]


# the order the roles are killed in, each once the one before is back; the token role of each
KILLS = (
    ("record", "recorder"),  # first: the time lost between its parts is measured without the router's restart
    ("collision", "collision"),
    ("sensors", "sensors"),
    ("radio", "radio"),
    ("agent", "agent"),
    ("world", "world"),
    ("router", "router"),
)


def test_every_role_killed_in_turn_comes_back_and_the_run_meets_its_criteria(tmp_path: Path) -> None:
    recording = tmp_path / "run.mcap"
    run = _Run(_scenario(tmp_path, duration_s=40), tmp_path, record=recording)
    recovered: dict[str, float] = {}
    try:
        run.wait_moving(timeout_s=60)
        for role, token in KILLS:
            pid = run.pid(role)
            before = wait_msg(run.states, WorldState, lambda m: 1 in m.ids, timeout_s=20)
            t0 = time.monotonic()
            subprocess.run(["kill", "-KILL", str(pid)], check=True, timeout=10)
            back = run.wait_token(token, since=t0)
            if role == "world":  # back means ticking again, from where it was
                st = wait_msg(run.states, WorldState, lambda m, b=before.tick: 1 in m.ids and m.tick > b, 30)
                back = time.monotonic()
                assert st.tick <= before.tick + 50, "the new world did not resume from the last tick"
            recovered[role] = back - t0
            run.wait_moving(timeout_s=30)  # and the chair drives again
        code, out = run.finish(timeout_s=90)
    finally:
        run.close()
    print("".join(line for line in out.splitlines(keepends=True) if "restart" in line or "back" in line))
    print("time to recover (kill to token back; the world: to ticking again):", recovered)
    assert code == 0, out
    assert "PASS robot 1 within 0.5 m of (8, 5)" in out
    assert "PASS collisions 0" in out
    for role, _ in KILLS:
        name = {"sensors": "sensors-1", "agent": "driver", "record": "recorder"}.get(role, role)
        assert f"{name} exited with -9; restarting it (1/3)" in out
        assert f"{name} is back" in out
        assert recovered[role] < 15.0, recovered
    assert "the new world resumes at tick" in out
    assert "the new recorder continues the recording in its next part" in out
    _the_recording_is_in_two_parts_and_mends(recording, out)


def _iwz(*args: str) -> subprocess.CompletedProcess[str]:
    argv = [sys.executable, "-m", "iw_zenoh.cli", *args]
    return subprocess.run(argv, capture_output=True, text=True, timeout=60, check=False, cwd=ROOT)


def _log_times(path: Path) -> list[int]:
    with path.open("rb") as f:  # this file alone (open_recording would read every part)
        return [r.log_time for r in RecordingReader(f).raw()]


def _the_recording_is_in_two_parts_and_mends(recording: Path, out: str) -> None:
    """The recorder killed once: part 1 cut off (or whole), part 2 whole, the cut mended by
    ``iwz recover``, and the log time between the parts about the 1 s budget at most."""
    part2 = recording.with_name("run.part2.mcap")
    assert f"recorded to {recording} in 2 parts (run.mcap, run.part2.mcap)" in out
    doctor = _iwz("doctor", str(recording))
    assert "run.part2.mcap (part 2 of 2): whole" in doctor.stdout, doctor.stdout
    part1 = recording
    if doctor.returncode != 0:  # killed mid-chunk, as it nearly always is: cut off, and mended
        assert "run.mcap (part 1 of 2): NOT whole" in doctor.stdout, doctor.stdout
        assert "cut off" in doctor.stdout, doctor.stdout
        assert f"iwz recover {recording}" in doctor.stdout, doctor.stdout
        mended = _iwz("recover", str(recording))
        assert mended.returncode == 0, mended.stdout + mended.stderr
        again = _iwz("doctor", str(recording))
        assert again.returncode == 0, again.stdout
        part1 = recording.with_name("run.recovered.mcap")
    else:
        assert "run.mcap (part 1 of 2): whole" in doctor.stdout, doctor.stdout
    last, first = max(_log_times(part1)), min(_log_times(part2))
    gap_s = (first - last) / 1e9
    how = "cut off, mended by iwz recover" if part1 != recording else "whole"
    print(f"part 1 of the recording {how}; log time lost between the parts: {gap_s:.3f} s")
    assert 0 < gap_s < 2.0  # the budget is 1 s; generous on a loaded machine


def test_an_agent_stopped_past_its_grace_drives_again_once_resumed(tmp_path: Path) -> None:
    run = _Run(_scenario(tmp_path, duration_s=60, world_fields="grace_ms = 1000"), tmp_path, status=True)
    try:
        run.wait_moving(timeout_s=60)
        pid = run.pid("agent")
        # the lines so far are not the status after the stop: one from before the agent was up may
        # say agents 0/1, robots 0/0 (and those since, agents 1/1, robots 1/1)
        while not run.lines.empty():
            run.lines.get_nowait()
        subprocess.run(["kill", "-STOP", str(pid)], check=True, timeout=10)
        try:
            wait_event(run.events, "removed", timeout_s=20, pred=lambda e: e.robot_id == 1)
            # the status line no longer counts the stopped agent nor its robot
            run.wait_line(lambda s: "agents 0/1" in s and "robots 0/0" in s, timeout_s=15)
        finally:
            subprocess.run(["kill", "-CONT", str(pid)], check=True, timeout=10)
        t0 = time.monotonic()
        wait_event(run.events, "registered", timeout_s=30, pred=lambda e: e.robot_id == 1)
        registered = time.monotonic() - t0
        run.wait_moving(timeout_s=30)
        run.wait_line(lambda s: "agents 1/1" in s and "robots 1/1" in s, timeout_s=15)
        print(f"registered again {registered:.2f} s after SIGCONT")
    finally:
        run.close()


def test_a_lockstep_world_killed_resumes_where_it_was_and_its_agents_answer_it(tmp_path: Path) -> None:
    # lock-step runs as fast as everyone answers: a long way, so the kills land on the way. (An
    # agent is not killed here: lock-step does not wait for the robots of an agent that is gone,
    # so the run races ahead while it restarts.)
    run = _Run(_scenario(tmp_path, duration_s=120, mode="lockstep", legs="18,5", goal_x=18.0), tmp_path)
    try:
        for role in ("world", "collision", "sensors", "world"):
            run.wait_moving(timeout_s=60)
            before = wait_msg(run.states, WorldState, lambda m: 1 in m.ids, timeout_s=20)
            subprocess.run(["kill", "-KILL", str(run.pid(role))], check=True, timeout=10)
            run.wait_token(role, since=time.monotonic() - 0.05)
            after = wait_msg(run.states, WorldState, lambda m, b=before.tick: 1 in m.ids and m.tick > b, 30)
            assert _at(after)[0] >= _at(before)[0] - 0.01  # from where it was, not from the start
        code, out = run.finish(timeout_s=90)
    finally:
        run.close()
    assert code == 0, out
    assert "PASS robot 1 within 0.5 m of (18, 5)" in out
    assert "laggard" not in out.split("events")[-1].split("}")[0], out
