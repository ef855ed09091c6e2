"""watch_supervisor: which processes watch the ``iwz run`` named in their environment."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from iw_zenoh.process.runtime import SUPERVISOR_ENV, watch_supervisor

pytestmark = pytest.mark.timeout(60)

WATCHING = "from iw_zenoh.process.runtime import watch_supervisor; import threading; watch_supervisor(0.05); threading.Event().wait(30)"


def test_nothing_is_watched_without_the_variable_or_for_a_live_process_not_the_parent(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(SUPERVISOR_ENV, raising=False)
    assert watch_supervisor() is None
    # not process ids: refused with a warning, never an exception (os.kill overflows on a huge one)
    for hostile in ("not a pid", "99999999999999999999", "0", "-1", "\u0661\u0662", "12 ", "1e3", "x" * 10_000):
        monkeypatch.setenv(SUPERVISOR_ENV, hostile)
        assert watch_supervisor() is None, hostile
    monkeypatch.setenv(SUPERVISOR_ENV, str(os.getpid()))  # alive, and not this process's parent
    assert watch_supervisor() is None
    assert SUPERVISOR_ENV not in os.environ  # taken out: what this process starts does not inherit it


def _with_its_supervisor_gone(code: str) -> subprocess.CompletedProcess[str]:
    """Python ``code`` run in a process whose ``iwz run`` (a process that has exited) is gone."""
    gone = subprocess.Popen(["true"])
    gone.wait(10)
    return subprocess.run(
        [sys.executable, "-c", code],
        env=dict(os.environ, **{SUPERVISOR_ENV: str(gone.pid)}),
        capture_output=True,
        text=True,
        timeout=40,
    )


def test_a_process_whose_supervisor_is_already_gone_stops_as_sigterm_would() -> None:
    p = _with_its_supervisor_gone(WATCHING)
    assert p.returncode == -signal.SIGTERM, p.stderr


# a process iwz run started that looks only once its iwz run is dead, not yet reaped (a zombie):
# its import of a role takes a second or more, the launcher may be killed meanwhile
LATE = (
    "import signal, sys, threading; stop = threading.Event(); signal.signal(signal.SIGTERM, lambda *_: stop.set());"
    " sys.stdin.readline(); from iw_zenoh.process.runtime import watch_supervisor;"
    " print('watching' if watch_supervisor(0.05) else 'not watching', flush=True); stop.wait(60)"
)
LAUNCHER = (
    "import os, subprocess, sys, threading;"
    f" c = subprocess.Popen([sys.executable, '-c', {LATE!r}], env=dict(os.environ, {SUPERVISOR_ENV}=str(os.getpid())));"
    " print(c.pid, flush=True); threading.Event().wait(60)"
)


def test_a_process_whose_supervisor_died_before_it_looked_stops_though_not_yet_reaped() -> None:
    launcher = subprocess.Popen(
        [sys.executable, "-c", LAUNCHER], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    assert launcher.stdout is not None
    assert launcher.stdin is not None
    child = 0
    try:
        child = int(launcher.stdout.readline())
        launcher.send_signal(signal.SIGKILL)
        os.waitid(os.P_PID, launcher.pid, os.WEXITED | os.WNOWAIT)  # dead, and left a zombie
        launcher.stdin.write("go\n")  # the child, which inherited the launcher's stdin, looks now
        launcher.stdin.flush()
        # the pipe ends when the child, which holds its write end too, has exited
        out, _ = launcher.communicate(timeout=30)
    finally:
        if child and _running(child):
            os.kill(child, signal.SIGKILL)
        launcher.kill()
        launcher.wait(10)
    assert out.split() == ["watching"]


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


# a process whose stop never comes (its handler does nothing, as one whose main thread is blocked)
DEAF = (
    "import signal, threading; from iw_zenoh.process.runtime import watch_supervisor;"
    " signal.signal(signal.SIGTERM, lambda *_: None); watch_supervisor(0.05, grace_s=0.5); threading.Event().wait(30)"
)


def test_a_process_that_does_not_stop_once_its_supervisor_is_gone_is_killed() -> None:
    p = _with_its_supervisor_gone(DEAF)
    assert p.returncode == -signal.SIGKILL, p.stderr
    assert "still running 0.5 s after: killing this process" in p.stderr
