"""iwz run never ends before its recorder has finished its file, and says so when it could not:
its own bus failing to close does not skip the ordered stop, and a recorder that did not end with
0 (a restarted one stopped before its handlers, one killed) fails the run (exit 1)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from iw_zenoh.bus import ZenohBus
from iw_zenoh.bus.net import free_port
from iw_zenoh.launch import launcher as launcher_mod
from iw_zenoh.launch.child import Child
from iw_zenoh.launch.launcher import Launcher, main
from iw_zenoh.scenario.file import load_scenario
from tests.support.scenarios import SCENARIO

# SIGTERM's default action (no handler): as a restarted recorder stopped before it installed its own
NO_HANDLER = "import time; print('ready', flush=True); time.sleep(60)"


def _scenario(tmp_path: Path) -> Path:
    (tmp_path / "lab.xml").write_text('<Lab Name="open" Width="20" Height="10"/>')
    (tmp_path / "judged.toml").write_text(SCENARIO)
    return tmp_path / "judged.toml"


def _stopped_while_deaf(tmp_path: Path, sim: str, *, seen: bool) -> Launcher:
    """A launcher whose only child is a recorder with no SIGTERM handler (``seen``: its token
    was seen), after its ordered stop."""
    launcher = Launcher(
        load_scenario(_scenario(tmp_path)), port=free_port(), sim=sim, log_dir=tmp_path / "logs", status=False
    )
    rec = Child("record", "recorder", [], tmp_path / "recorder.log", seen=seen)
    rec.proc = subprocess.Popen([sys.executable, "-c", NO_HANDLER], stdout=subprocess.PIPE)
    try:
        assert rec.proc.stdout is not None
        assert rec.proc.stdout.readline() == b"ready\n"
        rec.proc.stdout.close()
        launcher.children = [rec]
        launcher.shutdown()
        assert rec.proc.returncode == -15  # killed by the stop: its file (if any) not finished
    finally:
        if rec.proc.poll() is None:
            rec.proc.kill()
            rec.proc.wait(5)
    return launcher


def test_a_recorder_that_did_not_end_with_0_fails_the_run(tmp_path: Path) -> None:
    launcher = _stopped_while_deaf(tmp_path, "cut", seen=True)
    assert launcher.record_cut is not None  # print_summary fails the run on it: exit 1, "cut off" said


def test_a_recorder_that_ended_with_0_leaves_the_run_whole(tmp_path: Path) -> None:
    sc = load_scenario(_scenario(tmp_path))
    launcher = Launcher(sc, port=free_port(), sim="whole", log_dir=tmp_path / "logs", status=False)
    rec = Child("record", "recorder", [], tmp_path / "recorder.log", seen=True)
    rec.proc = subprocess.Popen([sys.executable, "-c", "pass"])
    rec.proc.wait(30)
    launcher.children = [rec]
    launcher.shutdown()
    assert launcher.record_cut is None


def test_the_children_are_stopped_even_when_the_launchers_bus_fails_to_close(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    class Unclosable:
        def close(self) -> None:
            raise RuntimeError("close operation timed out")  # zenoh's ZError on a starved machine

    stopped: list[bool] = []
    monkeypatch.setattr(launcher_mod, "stop_on_signals", lambda _event: None)  # not this worker's signals
    monkeypatch.setattr(Launcher, "start", lambda self: setattr(self, "bus", Unclosable()))
    monkeypatch.setattr(Launcher, "supervise", lambda self, bus: 0)
    monkeypatch.setattr(Launcher, "shutdown", lambda self, timeout_s=8.0: stopped.append(True))
    code = main([str(_scenario(tmp_path)), "--no-record", "--no-status", "--port", str(free_port())])
    assert code == 70  # iwz run's own failure, not a verdict
    assert stopped == [True]  # before: skipped, and the orphaned recorder still writing as iwz run exited 1


def test_iwz_runs_own_failure_is_not_read_as_a_verdict(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def fails(self: Launcher, bus: object) -> int:
        raise KeyError("a bug in the supervision")

    class Closable:
        def close(self) -> None:
            pass

    stopped: list[bool] = []
    monkeypatch.setattr(launcher_mod, "stop_on_signals", lambda _event: None)
    monkeypatch.setattr(Launcher, "start", lambda self: setattr(self, "bus", Closable()))
    monkeypatch.setattr(Launcher, "supervise", fails)
    monkeypatch.setattr(Launcher, "shutdown", lambda self, timeout_s=8.0: stopped.append(True))
    code = main([str(_scenario(tmp_path)), "--no-record", "--no-status", "--port", str(free_port())])
    assert code == 70  # not 1 (a criterion failed): a study reads 0 and 1 as a measured run
    assert stopped == [True]


def test_a_session_close_that_fails_is_said_not_raised(caplog: pytest.LogCaptureFixture) -> None:
    class Session:
        def is_closed(self) -> bool:
            return False

        def close(self) -> None:
            raise RuntimeError("close operation timed out")

    bus = object.__new__(ZenohBus)
    bus._handles, bus._pubs, bus.session = {}, {}, Session()  # type: ignore[assignment]
    bus.close()
    assert "did not close cleanly: close operation timed out" in caplog.text


def test_a_recorder_that_never_started_is_not_said_to_have_cut_the_recording(tmp_path: Path) -> None:
    """One that could not start (its error said, exit 3) or was stopped while starting (no
    handlers yet: -15) wrote nothing to cut off: the run's verdict so far stands."""
    launcher = _stopped_while_deaf(tmp_path, "unborn", seen=False)  # its token never seen
    assert launcher.record_cut is None
