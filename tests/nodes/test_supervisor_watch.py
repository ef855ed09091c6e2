"""watch_supervisor: which processes watch the ``iwz run`` named in their environment."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from iw_zenoh.runtime import SUPERVISOR_ENV, watch_supervisor

pytestmark = pytest.mark.timeout(60)

WATCHING = "from iw_zenoh.runtime import watch_supervisor; import threading; watch_supervisor(0.05); threading.Event().wait(30)"


def test_nothing_is_watched_without_the_variable_or_for_a_live_process_not_the_parent(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(SUPERVISOR_ENV, raising=False)
    assert watch_supervisor() is None
    monkeypatch.setenv(SUPERVISOR_ENV, "not a pid")
    assert watch_supervisor() is None
    monkeypatch.setenv(SUPERVISOR_ENV, str(os.getpid()))  # alive, and not this process's parent
    assert watch_supervisor() is None
    assert SUPERVISOR_ENV not in os.environ  # taken out: what this process starts does not inherit it


def test_a_process_whose_supervisor_is_already_gone_stops_as_sigterm_would() -> None:
    gone = subprocess.Popen(["true"])
    gone.wait(10)
    p = subprocess.run(
        [sys.executable, "-c", WATCHING],
        env=dict(os.environ, **{SUPERVISOR_ENV: str(gone.pid)}),
        capture_output=True,
        text=True,
        timeout=40,
    )
    assert p.returncode == -signal.SIGTERM, p.stderr
