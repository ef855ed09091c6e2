"""A recording whose disk fills up: the recorder says which file, why, how much it wrote and how
to mend it, and exits 4 (no traceback); ``iwz recover`` gets back what was written; ``iwz run``
does not restart it onto the same full disk (before: three empty parts, and a run that passed
with a summary naming four parts), goes on, and fails its verdict with the time the recording
stopped. ``iwz recover``, ``render`` and ``report`` writing to a full disk name the file they
write (before, the recording they read) and leave no piece of it. The disk is a real one: a
tmpfs of a few hundred kilobytes, mounted for the test."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.record.reader import RecordingReader
from tests.integration.harness import ROOT, Net, iwz_run_argv, scenario_in, stop_run, wait_alive

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

SAMPLE = ROOT / "recordings" / "demo-sample.mcap"

SCENARIO = """
name = "full"
[world]
map = "lab.xml"
grid = "grid.xml"
mode = "lockstep"
duration_s = 60
[[agents]]
program = "waypoint"
args = ["--id", "1", "--waypoints", "17,5;3,5;17,5"]
"""


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A 300 KB filesystem of its own (tmpfs), unmounted after the test."""
    where = tmp_path / "small"
    where.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", str(where)], capture_output=True)
    assert done.returncode == 0, f"this test mounts a tmpfs (root): {done.stderr.decode()}"
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], check=False)


def test_a_recorder_whose_disk_is_full_says_why_exits_4_and_what_it_wrote_is_recovered(
    net: Net, small_disk: Path
) -> None:
    out = small_disk / "hand.mcap"
    rec = net.spawn("record", "-o", str(out), "--quiet")
    bus = net.client()
    wait_alive(bus, keys.alive(net.sim, "recorder", "recorder"))
    sent = 0
    while rec.popen.poll() is None and sent < 5_000:  # ~10 MB that does not compress: 30 times the disk
        for _ in range(10):
            bus.publish(keys.actions(net.sim, 1), b'{"tick":%d,"x":"%s"}' % (sent, os.urandom(1000).hex().encode()))
            sent += 1
        time.sleep(0.05)  # load pacing (400 KB/s: chunks of about 100 KB, closed every 0.25 s), not synchronisation
    assert rec.popen.wait(60) == 4, rec.output()
    said = rec.output()
    assert "Traceback" not in said
    assert f"iwz record: cannot write {out}: No space left on device, after " in said
    assert f"`iwz recover {out}`" in said
    fixed = net.tmp / "fixed.mcap"  # where there is space
    done = subprocess.run(
        [sys.executable, "-m", "iw_zenoh.cli", "recover", str(out), "-o", str(fixed)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    with fixed.open("rb") as f:
        kept = sum(1 for _ in RecordingReader(f).raw(topics=lambda t: t == keys.actions(net.sim, 1)))
    assert kept > 50, f"only {kept} of the messages written before the disk filled were recovered"


def test_a_run_whose_recording_fills_its_disk_goes_on_unrecorded_and_fails_its_verdict(
    tmp_path: Path, small_disk: Path
) -> None:
    scenario_in(tmp_path, "full", SCENARIO)
    record = small_disk / "run.mcap"
    argv = iwz_run_argv(tmp_path / "full.toml", tmp_path / "logs", "full", record=record)
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        out, _ = p.communicate(timeout=180)
    finally:
        if p.poll() is None:
            stop_run(p)
    assert p.returncode == 1, out
    assert "recorder exited with 4" in out
    assert f"iwz record: cannot write {record}: No space left on device" in out
    assert "restarting it" not in out  # a new part on the same full disk would be as empty
    assert [f.name for f in small_disk.iterdir()] == ["run.mcap"]
    assert "  FAIL recording cut off at t=" in out
    assert "iwz run: ended at t=60.0 s" in out  # the run itself went on to its end
    assert f"iwz run: recorded to {record} until t=" in out


@pytest.mark.parametrize(
    ("command", "output", "said"),
    [
        (["recover", str(SAMPLE), "-o", "{out}"], "copy.mcap", "iwz recover: {out}: No space left on device"),
        (
            ["render", str(SAMPLE), "--at", "10", "-o", "{out}"],
            "at10.png",
            "iwz render: {out}: No space left on device",
        ),
        (["report", str(SAMPLE), "--html", "{out}"], "page.html", "iwz report: --html {out}: cannot write it"),
    ],
)
def test_a_tool_writing_to_a_full_disk_names_its_output_and_leaves_no_piece_of_it(
    small_disk: Path, command: list[str], output: str, said: str
) -> None:
    (small_disk / "filler").write_bytes(os.urandom(296 * 1024))  # 4 KB left: less than any of them writes
    out = small_disk / output
    argv = [a.format(out=out) for a in command]
    done = subprocess.run([sys.executable, "-m", "iw_zenoh.cli", *argv], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stdout + done.stderr
    assert said.format(out=out) in done.stdout + done.stderr  # the file it writes, not the one it reads
    assert "Traceback" not in done.stdout + done.stderr
    assert not out.exists()  # a file cut off is of no use, and holds the space it took
