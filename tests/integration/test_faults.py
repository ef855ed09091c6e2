"""Every role survives its own death during an ``iwz run``: killed, it comes back and the run goes
on to meet its criteria (a killed recorder goes on in the next part of the recording); an agent
stopped past the grace period drives again once resumed."""

from __future__ import annotations

import queue
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.bus.net import NetConfig, free_port
from iw_zenoh.messages import WorldState
from iw_zenoh.record.reader import RecordingReader
from tests.integration.harness import ROOT, stop_run, subscribe, wait_event, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(170)]

LAB = """<Lab Name="faults" Width="20" Height="10">
  <Wall Height="2"><Corner X="9" Y="0"/><Corner X="10" Y="0"/><Corner X="10" Y="3"/><Corner X="9" Y="3"/></Wall>
</Lab>"""
GRID = """<Grid><Position X="2" Y="5" Dir="0"/><Position X="2" Y="8" Dir="0"/></Grid>"""
LEGS = ";".join(["8,5;3,5"] * 20)  # back and forth for as long as the run lasts


def _scenario(
    tmp: Path, *, duration_s: float, world_args: str = "", mode: str = "realtime", legs: str = LEGS, goal_x: float = 8.0
) -> Path:
    (tmp / "lab.xml").write_text(LAB)
    (tmp / "grid.xml").write_text(GRID)
    path = tmp / "faults.toml"
    path.write_text(
        f"""name = "faults"
[world]
map = "lab.xml"
grid = "grid.xml"
mode = "{mode}"
duration_s = {duration_s}
args = [{world_args}]
[[agents]]
program = "waypoint"
name = "driver"
args = ["--id", "1", "--speed", "0.15", "--waypoints", "{legs}"]
[criteria]
max_collisions = 0
stop_when_reached = {"false" if legs == LEGS else "true"}
[[criteria.reach]]
robot = 1
x = {goal_x}
y = 5.0
within = 0.5
"""
    )
    return path


class _Run:
    """An ``iwz run`` of the scenario, its output read as it comes, and the test's own session."""

    def __init__(self, scenario: Path, tmp: Path, *, status: bool = False, record: Path | None = None) -> None:
        self.port = free_port()
        self.sim = "faults"
        argv = [sys.executable, "-m", "iw_zenoh.cli", "run", str(scenario), "--port", str(self.port)]
        argv += ["--sim", self.sim, "--log-dir", str(tmp / "logs")]
        argv += ["--record", str(record)] if record is not None else ["--no-record"]
        argv += [] if status else ["--no-status"]
        self.p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT)
        self.lines: queue.Queue[str] = queue.Queue()
        self.out: list[str] = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()
        self.bus = ZenohBus(NetConfig(connect=(f"tcp/127.0.0.1:{self.port}",)))
        self.states = subscribe(self.bus, keys.state(self.sim), maxlen=1)
        self.events = subscribe(self.bus, keys.all_events(self.sim))
        self.tokens: queue.Queue[tuple[str, bool, float]] = queue.Queue()
        self.bus.watch_alive(keys.all_alive(self.sim), lambda k, a: self.tokens.put((k, a, time.monotonic())))

    def _read(self) -> None:
        assert self.p.stdout is not None
        for line in self.p.stdout:
            self.out.append(line)
            self.lines.put(line)

    def pid(self, role: str, name: str = "") -> int:
        """The pid of the launcher's child of ``role`` (and ``--name NAME``)."""
        for proc in Path("/proc").iterdir():
            if not proc.name.isdigit():
                continue
            try:
                argv = (proc / "cmdline").read_bytes().split(b"\0")
                ppid = int((proc / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
            args = [a.decode(errors="replace") for a in argv]
            if ppid == self.p.pid and args[3:4] == [role] and (not name or name in args):
                return int(proc.name)
        raise AssertionError(f"no {role} child of the launcher")

    def wait_token(self, role: str, since: float, timeout_s: float = 30.0) -> float:
        """When a token of ``role`` appeared after ``since`` (monotonic s)."""
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            try:
                key, alive, at = self.tokens.get(timeout=left)
            except queue.Empty:
                break
            parts = keys.alive_parts(key)
            if alive and parts and parts[0] == role and at > since:
                return at
        raise AssertionError(f"no {role} token within {timeout_s} s:\n{''.join(self.out)}")

    def wait_moving(self, timeout_s: float = 30.0) -> WorldState:
        """A state where robot 1 moved since a state five ticks before."""
        first = wait_msg(self.states, WorldState, lambda m: 1 in m.ids, timeout_s)
        x0, y0 = _at(first)

        def moved(m: WorldState) -> bool:
            x, y = _at(m)
            return m.tick >= first.tick + 5 and abs(x - x0) + abs(y - y0) > 0.05

        return wait_msg(self.states, WorldState, lambda m: 1 in m.ids and moved(m), timeout_s)

    def wait_line(self, pred: object, timeout_s: float) -> str:
        """The first output line from now on for which ``pred`` holds."""
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            try:
                line = self.lines.get(timeout=left)
            except queue.Empty:
                break
            if callable(pred) and pred(line):
                return line
        raise AssertionError(f"no such line within {timeout_s} s:\n{''.join(self.out)}")

    def finish(self, timeout_s: float) -> tuple[int, str]:
        """Waits for the run to end by itself (its duration); its code and output."""
        try:
            self.p.wait(timeout_s)
        except subprocess.TimeoutExpired:
            stop_run(self.p)
            pytest.fail(f"the run did not end within {timeout_s} s:\n{''.join(self.out)}")
        self.reader.join(10)  # the last lines, read once the pipe closed
        return self.p.returncode, "".join(self.out)

    def close(self) -> None:
        self.bus.close()
        if self.p.poll() is None:
            stop_run(self.p)
        self.reader.join(10)
        if self.p.stdout is not None:
            self.p.stdout.close()


def _at(m: WorldState) -> tuple[float, float]:
    i = m.ids.index(1)
    return m.x[i], m.y[i]


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
    run = _Run(_scenario(tmp_path, duration_s=60, world_args='"--grace-ms", "1000"'), tmp_path, status=True)
    try:
        run.wait_moving(timeout_s=60)
        pid = run.pid("agent")
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
