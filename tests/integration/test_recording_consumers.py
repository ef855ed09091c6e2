"""Recordings open in the tools people use: a fresh ``iwz run`` recording with a laser chair, a
continued part and a recorder started beside a running simulation, every channel checked by
Foxglove's and Lichtblick's rules (tests/support/consumer.py) and every message against its schema
with a draft-07 and a 2020-12 validator; the continued part and the late recording are
self-contained (the world's description in each) and ``iwz render`` draws their walls and chairs."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from iw_zenoh import keys
from iw_zenoh.messages import WorldState
from tests.integration.browser import record_run
from tests.integration.harness import Net, subscribe, wait_alive, wait_msg
from tests.support.consumer import check_recording

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(300)]

AGENTS = """[[agents]]
program = "waypoint"
args = ["--waypoints", "12,5", "--start", "5,5,0", "--robot-name", "scanner", "--id", "1"]
name = "scanner-agent"
spec = { lasers = [{ id = 0, x_m = 0.5, fov_deg = 180, beams = 9, range_m = 3 }], noise = false }
"""
LAB = """<Lab Name="walls" Width="20" Height="10">
  <Wall Height="2"><Corner X="9" Y="0"/><Corner X="10" Y="0"/><Corner X="10" Y="3"/><Corner X="9" Y="3"/></Wall>
</Lab>"""
WALL_RGB = (0.35, 0.35, 0.35)  # render.py draws walls in matplotlib's "0.35"
CHAIR_RGB = (0.12, 0.47, 0.71)  # and the first chair in tab10's first colour


def _iwz(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "iw_zenoh.cli", *args], capture_output=True, text=True, timeout=120, check=False
    )


def _has(img: np.ndarray, rgb: tuple[float, float, float]) -> int:
    return int(np.sum(np.all(np.abs(img[..., :3] - np.array(rgb)) < 0.03, axis=-1)))


def _draws_walls_and_chairs(path: Path, at_s: float) -> None:
    png = path.with_suffix(".png")
    r = _iwz("render", str(path), "--at", f"{at_s:g}", "-o", str(png))
    assert r.returncode == 0, r.stdout + r.stderr
    img = matplotlib.image.imread(png)
    assert _has(img, WALL_RGB) > 50, "no wall drawn"
    assert _has(img, CHAIR_RGB) > 20, "no chair drawn"


def test_a_fresh_iwz_run_recording_with_a_laser_chair_follows_the_consumers_rules(tmp_path: Path) -> None:
    rec = record_run(tmp_path, "fresh", name="consumers", agents=AGENTS)
    checked = check_recording(rec)
    assert keys.info("fresh") in checked
    assert "/foxglove/laser/1/0" in checked  # the scanner's own Foxglove LaserScan channel
    assert {"/foxglove/scene", "/foxglove/tf"} <= checked.keys()


def test_a_continued_part_and_a_late_recording_are_self_contained_and_drawn(net: Net) -> None:
    (net.tmp / "lab.xml").write_text(LAB)
    out, late, part2 = net.tmp / "run.mcap", net.tmp / "late.mcap", net.tmp / "run.part2.mcap"
    argv = ("-o", str(out), "--quiet", "--continue", "run-1")
    bus = net.client()
    states = subscribe(bus, keys.state(net.sim), maxlen=1)
    rec = net.spawn("record", *argv)
    wait_alive(bus, keys.alive(net.sim, "recorder", "recorder"))
    run = [
        net.spawn("world", str(net.tmp / "lab.xml")),
        net.spawn("collision"),
        net.spawn("sensors"),
        net.spawn("agent", "waypoint", "--waypoints", "7,5", "--start", "3,5,0", "--name", "driver"),
    ]
    at = wait_msg(states, WorldState, lambda m: m.tick >= 20 and bool(m.ids), timeout_s=60).tick
    rec.kill(signal.SIGKILL)
    again = net.spawn("record", *argv, name="recorder-2")  # as the launcher restarts it
    beside = net.spawn("record", "-o", str(late), "--quiet", name="late-recorder")  # a user's, started late
    deadline = time.monotonic() + 60
    while not (late.exists() and part2.exists()):  # each opens its file once it listens
        assert time.monotonic() < deadline, beside.output() + again.output()
        time.sleep(0.05)  # polling for a file: there is no event to wait on
    at = wait_msg(states, WorldState, lambda m: m.tick >= at + 10, timeout_s=60).tick  # both recording
    wait_msg(states, WorldState, lambda m: m.tick >= at + 40, timeout_s=60)
    for proc in run:
        proc.kill(signal.SIGINT)
    for proc in (again, beside):
        proc.popen.send_signal(signal.SIGINT)
        assert proc.popen.wait(60) == 0, proc.output()
    for path in (part2, late):
        checked = check_recording(path)
        assert keys.info(net.sim) in checked, f"{path.name}: no world description: {sorted(checked)}"
        assert {"/foxglove/scene", "/foxglove/tf"} <= checked.keys(), sorted(checked)
        doctor = _iwz("doctor", str(path))
        assert "no world description" not in doctor.stdout, doctor.stdout
    # a moment both files hold (simulation seconds): after the restart and the late start
    _draws_walls_and_chairs(part2, (at + 30) / 10)
    _draws_walls_and_chairs(late, (at + 30) / 10)
