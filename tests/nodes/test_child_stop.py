"""iwz run's stop: a recorder is given the time to finish its file; any other child that does not
stop is killed after the launcher's timeout."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from iw_zenoh.launch.child import RECORDER_STOP_S, Child, stop_in_order
from iw_zenoh.nodes.recorder import DRAIN_MAX_S

# a process that takes a while to stop after SIGTERM (a recorder writing its backlog, then its index)
SLOW = (
    "import signal, sys, time\n"
    "signal.signal(signal.SIGTERM, lambda *a: (time.sleep(1.5), sys.exit(0)))\n"
    "print('ready', flush=True)\n"
    "time.sleep(60)"
)


def _child(role: str, tmp: Path) -> Child:
    c = Child(role=role, name=role, argv=[], log=tmp / f"{role}.log")
    c.proc = subprocess.Popen([sys.executable, "-c", SLOW], stdout=subprocess.PIPE)
    assert c.proc.stdout is not None
    assert c.proc.stdout.readline() == b"ready\n"  # its SIGTERM handler is in place
    c.proc.stdout.close()
    return c


def test_the_recorder_is_waited_for_past_the_timeout_and_finishes(tmp_path: Path) -> None:
    rec = _child("record", tmp_path)
    try:
        stop_in_order([rec], timeout_s=0.3)
        assert rec.proc is not None
        assert rec.proc.returncode == 0  # it finished on its own, not killed (-9)
    finally:
        if rec.proc is not None and rec.proc.poll() is None:
            rec.proc.kill()


def test_another_child_that_does_not_stop_in_time_is_killed(tmp_path: Path) -> None:
    other = _child("collision", tmp_path)
    try:
        stop_in_order([other], timeout_s=0.3)
        assert other.proc is not None
        assert other.proc.returncode == -9
    finally:
        if other.proc is not None and other.proc.poll() is None:
            other.proc.kill()


def test_the_recorder_is_given_longer_than_it_may_write_after_a_stop() -> None:
    assert RECORDER_STOP_S > DRAIN_MAX_S + 5
