"""A run whose ``iwz run`` is gone stops, every process of it: killed (SIGKILL, out of memory),
each process it started sees its parent go and stops as SIGTERM would (the recording finished,
the router's port free again); its terminal closed (SIGHUP), the launcher stops the run in order
and prints its summary. Before, both left the router, the world and the agents running. A role
started by hand whose terminal is closed stops as Ctrl-C would (before, SIGHUP cut a recording
off where it stood)."""

from __future__ import annotations

import contextlib
import os
import pty
import signal
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.bus.net import NetConfig, free_port, port_in_use
from iw_zenoh.launch.launcher import Launcher
from iw_zenoh.messages import ChairReading, WorldState
from iw_zenoh.record.reader import RecordingReader
from iw_zenoh.record.tools import check
from iw_zenoh.scenario.file import load_scenario
from tests.integration.harness import Net, iwz_run_argv, scenario_in, stop_run, subscribe, wait_alive, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

SCENARIO = """
name = "gone"
[world]
map = "lab.xml"
grid = "grid.xml"
mode = "realtime"
duration_s = 120
[[agents]]
program = "waypoint"
args = ["--id", "1", "--waypoints", "17,5;3,5;17,5"]
"""
# a [chair] without a port: iwz run starts the chair emulator on a pty (not a role: its own main)
# and the serial bridge that registers robot 1
CHAIR_SCENARIO = """
name = "gone"
[world]
map = "lab.xml"
mode = "realtime"
duration_s = 120
[chair]
robot = 1
start = { x_m = 3.0, y_m = 5.0, dir_deg = 0.0 }
"""


def _children(pid: int) -> list[int]:
    """The processes whose parent is ``pid``."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(entry.name))
    return out


def _running(pid: int) -> bool:
    """Whether ``pid`` is a process that has not exited (a zombie nobody reaped has)."""
    try:
        return (Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]) != "Z"
    except OSError:
        return False


def _wait_gone(pids: list[int], timeout_s: float) -> list[int]:
    """Waits until none of ``pids`` runs; those still running after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while (left := [p for p in pids if _running(p)]) and time.monotonic() < deadline:
        time.sleep(0.2)  # polling /proc: an exit of a process not ours gives no event
    return left


def _start(
    tmp: Path, scenario: str = SCENARIO, record: bool = True
) -> tuple[subprocess.Popen[str], int, list[int], Path]:
    """``iwz run`` of a long real-time run, once its world steps with robot 1 registered (every
    process started: the agents, or the serial bridge, start last) and, a run with a ``[chair]``,
    once the bridge hears the chair (the emulator's pty made and linked: the bridge registers
    robot 1 before, its device looked for until it is there): the launcher, its router's port,
    the processes it started, the recording."""
    scenario_in(tmp, "gone", scenario)
    out = tmp / "run.mcap"
    argv = iwz_run_argv(tmp / "gone.toml", tmp / "logs", "gone", record=out if record else None)
    port = int(argv[argv.index("--port") + 1])
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        bus = ZenohBus(NetConfig(connect=(f"tcp/127.0.0.1:{port}",)))
        try:
            states = subscribe(bus, keys.state("gone"))
            chair = subscribe(bus, keys.chair("gone", 1))
            wait_msg(states, WorldState, lambda m: m.tick >= 10 and 1 in m.ids, timeout_s=90)
            if "[chair]" in scenario:
                wait_msg(chair, ChairReading, lambda m: m.link == "up", timeout_s=60)
        finally:
            bus.close()
        children = _children(p.pid)
    except BaseException:
        stop_run(p)
        raise
    return p, port, children, out


def _of_sim(sim: str) -> list[int]:
    """The processes whose command line names simulation ``sim`` (every process of a run does)."""
    out = []
    for entry in Path("/proc").iterdir():
        try:
            argv = (entry / "cmdline").read_bytes().split(b"\0") if entry.name.isdigit() else []
        except OSError:
            continue
        if any(a == b"--sim" and b == sim.encode() for a, b in zip(argv, argv[1:], strict=False)):
            out.append(int(entry.name))
    return out


def _recorded_ticks(record: Path) -> list[int]:
    """The ticks of the states in a recording that was finished (its summary written, nothing
    cut off)."""
    with record.open("rb") as f:
        reader = RecordingReader(f)
        assert reader.summary() is not None
        ticks = [r.message.tick for r in reader.records(["state"]) if isinstance(r.message, WorldState)]
        assert not reader.notes
        return ticks


def _report(pids: list[int], logs: Path) -> str:
    """What a failure needs to explain itself: each of ``pids`` still there (its state and
    command line) and the tail of each log of the run."""
    lines = []
    for pid in pids:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
            argv = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            state, argv = "gone", ""
        lines.append(f"pid {pid} ({state}): {argv[:300]}")
    for log in sorted(logs.glob("*.log")):
        lines += [f"== {log.name}", *log.read_text(errors="replace").splitlines()[-15:]]
    return "\n".join(lines)


def _kill(pids: list[int]) -> None:
    for pid in pids:
        if _running(pid):
            os.kill(pid, signal.SIGKILL)


def test_a_killed_launcher_leaves_nothing_running_and_its_recording_finished(tmp_path: Path) -> None:
    p, port, children, record = _start(tmp_path)
    try:
        # router, recorder, world, collision, sensors, the agent
        assert len(children) >= 6, children
        p.kill()
        p.wait(10)
        left = _wait_gone(children, timeout_s=60)
        assert not left, f"still running 60 s after their iwz run was killed:\n{_report(left, tmp_path / 'logs')}"
    finally:
        _kill(children)
        if p.stdout:
            p.stdout.close()
    assert not port_in_use(port)
    assert len(_recorded_ticks(record)) >= 10
    logs = "\n".join(f.read_text(errors="replace") for f in (tmp_path / "logs").glob("*.log"))
    assert f"the iwz run that started this process (pid {p.pid}) is gone: stopping" in logs


def test_a_launcher_hung_up_stops_the_run_and_prints_its_summary(tmp_path: Path) -> None:
    p, port, children, record = _start(tmp_path)
    try:
        p.send_signal(signal.SIGHUP)
        out, _ = p.communicate(timeout=90)
        left = _wait_gone(children, timeout_s=10)
    finally:
        _kill(children)
        if p.poll() is None:
            stop_run(p)
    assert not left, f"still running after their iwz run stopped: {left}\n{out}"
    assert p.returncode == 0, out
    assert f"iwz run: recorded to {record}" in out, out
    assert not port_in_use(port)
    assert len(_recorded_ticks(record)) >= 10


def test_a_launcher_in_a_terminal_that_is_closed_ends_with_its_verdict_not_an_error(tmp_path: Path) -> None:
    # a real terminal: iwz run on a pseudo-terminal that is its controlling terminal; closing
    # the master end hangs it up (the kernel sends SIGHUP), and every write to it fails from then
    scenario_in(tmp_path, "gone", SCENARIO)
    record = tmp_path / "run.mcap"
    argv = iwz_run_argv(tmp_path / "gone.toml", tmp_path / "logs", "gone", record=record)
    argv.remove("--no-status")  # the status line too, every second on a terminal
    port = int(argv[argv.index("--port") + 1])
    pid, master = pty.fork()
    if pid == 0:  # the child: exec at once
        os.execv(argv[0], argv)
    children: list[int] = []
    try:
        bus = ZenohBus(NetConfig(connect=(f"tcp/127.0.0.1:{port}",)))
        try:
            states = subscribe(bus, keys.state("gone"))
            wait_msg(states, WorldState, lambda m: m.tick >= 20 and 1 in m.ids, timeout_s=90)
        finally:
            bus.close()
        children = _children(pid)
        os.close(master)  # the terminal closed
        master = -1
        status = _wait_exit(pid, timeout_s=90)
        left = _wait_gone(children, timeout_s=10)
    finally:
        if master >= 0:
            os.close(master)
        _kill([*children, pid])
        with contextlib.suppress(ChildProcessError):
            os.waitpid(pid, 0)
    assert not left, f"still running after their iwz run stopped: {left}"
    assert status == 0, f"iwz run ended with status {status} (a traceback writing to its closed terminal?)"
    assert not port_in_use(port)
    assert len(_recorded_ticks(record)) >= 20


def _wait_exit(pid: int, timeout_s: float) -> int | None:
    """The exit status of child ``pid`` once it ends (-N for a signal N), None if still up after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            return os.waitstatus_to_exitcode(status)
        time.sleep(0.1)  # polling waitpid: a child's exit gives no other event here
    return None


def test_a_recorder_started_by_hand_whose_terminal_closed_finishes_its_file(net: Net) -> None:
    out = net.tmp / "hand.mcap"
    rec = net.spawn("record", "-o", str(out), "--quiet")
    bus = net.client()
    wait_alive(bus, keys.alive(net.sim, "recorder", "recorder"))
    for tick in range(1, 51):
        bus.publish(keys.actions(net.sim, 1), b'{"tick":%d,"robot_id":1}' % tick)
    marker = subscribe(bus, keys.event(net.sim, "mark"))
    bus.publish(keys.event(net.sim, "mark"), b'{"kind":"mark"}')
    assert marker.get(timeout_s=10) is not None  # our own last message made the round trip
    rec.popen.send_signal(signal.SIGHUP)
    assert rec.popen.wait(60) == 0, rec.output()
    h = check(out)
    assert h.whole, h.reason
    with out.open("rb") as f:
        reader = RecordingReader(f)
        assert sum(1 for _ in reader.raw(topics=lambda t: t == keys.actions(net.sim, 1))) == 50


def test_a_killed_launcher_leaves_no_chair_emulator_running(tmp_path: Path) -> None:
    p, port, children, _ = _start(tmp_path, CHAIR_SCENARIO, record=False)
    logs = tmp_path / "logs"
    link = logs / "chair-pty"
    try:
        emulators = [c for c in children if b"emulate" in Path(f"/proc/{c}/cmdline").read_bytes()]
        assert len(emulators) == 1, _report(children, logs)
        assert link.is_symlink(), _report(emulators, logs)  # the bridge heard the chair through it
        p.kill()
        p.wait(10)
        left = _wait_gone(children, timeout_s=60)
        assert not left, f"still running 60 s after their iwz run was killed:\n{_report(left, logs)}"
    finally:
        _kill(children)
        if p.stdout:
            p.stdout.close()
    assert not port_in_use(port), f"port {port} still taken:\n{_report(children, logs)}"
    # the emulator stopped as on SIGTERM: its pty closed, its link taken away
    assert not link.is_symlink(), _report(emulators, logs)


def test_a_launcher_hung_up_while_it_starts_the_run_stops_it_with_no_error(tmp_path: Path) -> None:
    scenario_in(tmp_path, "gone", SCENARIO)
    sim = f"hup{os.getpid()}"  # its processes, told from any other run's
    argv = iwz_run_argv(tmp_path / "gone.toml", tmp_path / "logs", sim, record=tmp_path / "run.mcap")
    port = int(argv[argv.index("--port") + 1])
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    left: list[int] = []
    try:
        deadline = time.monotonic() + 60
        while not port_in_use(port):
            assert p.poll() is None, p.communicate()[0]
            assert time.monotonic() < deadline, "the router did not listen in 60 s"
            time.sleep(0.02)  # polling a port: there is no event to wait on
        p.send_signal(signal.SIGHUP)  # the launcher now starts the recorder, and waits for it (a second or more)
        out, _ = p.communicate(timeout=90)
    finally:
        if p.poll() is None:
            stop_run(p)
        left = [pid for pid in _of_sim(sim) if _running(pid)]
        _kill(left)
    assert p.returncode == 0, out
    assert "did not start" not in out, out
    assert not left, f"still running after their iwz run stopped: {left}"


def test_a_stop_that_comes_while_the_recorder_starts_is_a_stop_not_a_failure(tmp_path: Path) -> None:
    scenario_in(tmp_path, "gone", SCENARIO)
    sc = load_scenario(tmp_path / "gone.toml")
    launcher = Launcher(
        sc,
        port=free_port(),
        sim=f"stop{os.getpid()}",
        log_dir=tmp_path / "logs",
        status=False,
        record=tmp_path / "run.mcap",
    )
    launcher.stop_event.set()  # a SIGTERM or SIGHUP before the recorder is heard from
    try:
        launcher.start()  # before: IwError "the recorder did not start", iwz run's exit 3
        started = sorted(c.role for c in launcher.children if c.proc is not None)
    finally:
        if launcher.bus is not None:
            launcher.bus.close()
        launcher.shutdown()
    assert started == ["record", "router"]  # and nothing more once stopped


def _wait_said(proc_output: Callable[[], str], words: str, timeout_s: float) -> None:
    """Waits until a process's output holds ``words``."""
    deadline = time.monotonic() + timeout_s
    while words not in proc_output():
        assert time.monotonic() < deadline, f"never said {words!r}:\n{proc_output()}"
        time.sleep(0.05)  # polling its log file: a write gives no event


def test_a_recorder_stopped_beside_a_live_run_finishes_at_a_second_ctrl_c(net: Net) -> None:
    """Beside a simulation that goes on, the bus is never quiet, so a stopped recorder drains
    for its whole 30 s: it says so, and a second Ctrl-C finishes the file at once (before, it
    went on recording for 30 s whatever one pressed, and a user's kill -9 cut the file off)."""
    out = net.tmp / "live.mcap"
    rec = net.spawn("record", "-o", str(out), "--quiet")
    bus = net.client()
    wait_alive(bus, keys.alive(net.sim, "recorder", "recorder"))
    done, going = threading.Event(), threading.Event()

    def live() -> None:  # a run that goes on: a message every 10 ms
        tick = 0
        while not done.wait(0.01):
            tick += 1
            bus.publish(keys.actions(net.sim, 1), b'{"tick":%d,"robot_id":1}' % tick)
            if tick == 20:
                going.set()

    publisher = threading.Thread(target=live, daemon=True)
    publisher.start()
    try:
        # the first 20 messages are in the recorder's queue before it is stopped: they went out
        # before a mark whose round trip through the router comes back to us
        assert going.wait(20)
        marker = subscribe(bus, keys.event(net.sim, "mark"))
        bus.publish(keys.event(net.sim, "mark"), b'{"kind":"mark"}')
        assert marker.get(timeout_s=10) is not None
        rec.popen.send_signal(signal.SIGINT)
        _wait_said(rec.output, "Ctrl-C again to finish the file now", 20)
        t0 = time.monotonic()
        rec.popen.send_signal(signal.SIGINT)
        assert rec.popen.wait(15) == 0, rec.output()
        assert time.monotonic() - t0 < 10, rec.output()
    finally:
        done.set()
        publisher.join(5)
    h = check(out)
    assert h.whole, h.reason
    with out.open("rb") as f:
        assert sum(1 for _ in RecordingReader(f).raw(topics=lambda t: t == keys.actions(net.sim, 1))) >= 20
