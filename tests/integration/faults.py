"""A run whose processes the fault tests kill and restart: its scenario, the run, where a robot is."""

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
from tests.integration.harness import ROOT, stop_run, subscribe, wait_msg

LAB = """<Lab Name="faults" Width="20" Height="10">
  <Wall Height="2"><Corner X="9" Y="0"/><Corner X="10" Y="0"/><Corner X="10" Y="3"/><Corner X="9" Y="3"/></Wall>
</Lab>"""


GRID = """<Grid><Position X="2" Y="5" Dir="0"/><Position X="2" Y="8" Dir="0"/></Grid>"""


LEGS = ";".join(["8,5;3,5"] * 20)  # back and forth for as long as the run lasts


def fault_scenario(
    tmp: Path,
    *,
    duration_s: float,
    world_fields: str = "",
    mode: str = "realtime",
    legs: str = LEGS,
    goal_x: float = 8.0,
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
{world_fields}
[[agents]]
program = "waypoint"
name = "driver"
args = ["--id", "1", "--speed", "0.15", "--waypoints", "{legs}"]
[criteria]
max_collisions = 0
stop_when_reached = {"false" if legs == LEGS else "true"}
[[criteria.reach]]
robot = 1
x_m = {goal_x}
y_m = 5.0
within_m = 0.5
"""
    )
    return path


class FaultRun:
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
        try:
            for line in self.p.stdout:
                self.out.append(line)
                self.lines.put(line)
        except (ValueError, OSError):  # closed by close() while this thread read: the run is over
            return

    def pid(self, role: str, name: str = "", timeout_s: float = 30.0) -> int:
        """The pid of the launcher's child of ``role`` (and ``--name NAME``), waiting up to
        ``timeout_s`` for it to be there (a restart may be under way: CI once looked in the moment
        between a restarted role's end and its next start)."""
        deadline = time.monotonic() + timeout_s
        while True:
            found = self._child(role, name)
            if found is not None:
                return found
            if time.monotonic() > deadline:
                raise AssertionError(
                    f"no {role} child of the launcher in {timeout_s:.0f} s:\n{''.join(self.out)[-3000:]}"
                )
            time.sleep(0.1)  # polling /proc: no event says a process has started

    def _child(self, role: str, name: str) -> int | None:
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
        return None

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
        x0, y0 = position_of(first)

        def moved(m: WorldState) -> bool:
            x, y = position_of(m)
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


def position_of(m: WorldState) -> tuple[float, float]:
    i = m.ids.index(1)
    return m.x[i], m.y[i]
