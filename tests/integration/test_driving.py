"""A person drives a chair through real processes (docs/driving.md): a driver's input on the
drive key moves the `manual` chair, one driver at a time (taking over is explicit), the agent's
dead-man stops the chair when the input stops; and the committed input trace drives
`slalom-manual` to PASS, with `iwz report`'s driving rows read from its recording."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.messages import DriveInput, DriveState, WorldState, encode
from tests.integration.harness import MAPS, Net, iwz_run_argv, start_world, stop_run, subscribe, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(300)]

TRACE = MAPS / "scenarios" / "slalom-manual.trace.jsonl"


class Driver:
    """A driver sending its stick at 20 Hz from the test's own session, as the page does."""

    def __init__(self, bus: ZenohBus, sim: str, name: str, **stick: float) -> None:
        self.bus, self.key, self.name, self.stick = bus, keys.drive(sim, 1), name, stick
        self.stop = threading.Event()
        self.last_sent = 0.0
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        seq = 0
        while not self.stop.wait(0.05):  # the page's steady rate (pacing, not synchronisation)
            msg = DriveInput(robot_id=1, driver=self.name, seq=seq, buttons=1, level=5, **self.stick)  # type: ignore[arg-type]
            self.bus.publish(self.key, encode(msg))
            self.last_sent = time.monotonic()
            seq += 1

    def leave(self) -> float:
        """Stops sending (the page closed); when the last input went."""
        self.stop.set()
        self.thread.join(5)
        return self.last_sent


def test_a_driver_drives_the_chair_one_at_a_time_and_the_dead_man_stops_it(net: Net) -> None:
    start_world(net, "collision", "sensors")
    net.spawn("agent", "manual", "--id", "1", "--start", "3,5,0", "--assist", "safe", "--name", "seat")
    bus = net.client()
    driving = subscribe(bus, keys.driving(net.sim, 1))
    states = subscribe(bus, keys.state(net.sim), maxlen=1)
    free = wait_msg(driving, DriveState, timeout_s=60)  # the chair says it takes a driver
    assert (free.driver, free.assist) == ("", "safe")

    a = Driver(bus, net.sim, "page-a", y=1.0)
    try:
        wait_msg(driving, DriveState, lambda s: s.driver == "page-a" and s.v_mps > 0.0)
        wait_msg(states, WorldState, lambda s: 1 in s.ids and s.x[s.ids.index(1)] > 3.3)  # forward
        bus.publish(keys.drive(net.sim, 1), encode(DriveInput(robot_id=1, driver="page-b", y=-1.0, buttons=1)))
        st = wait_msg(driving, DriveState, lambda s: s.refused == "page-b")
        assert st.driver == "page-a"
        assert st.v_mps > 0.0
    finally:
        last = a.leave()
    stale = wait_msg(driving, DriveState, lambda s: s.stale)
    waited = time.monotonic() - last
    assert (stale.v_mps, stale.w_radps) == (0.0, 0.0)
    assert waited < 2.0, f"the dead-man tripped {waited:.2f} s after the last input (300 ms and a tick, loaded)"
    wait_msg(states, WorldState, lambda s: abs(s.speed[s.ids.index(1)]) < 1e-3)  # the chair stopped

    bus.publish(keys.drive(net.sim, 1), encode(DriveInput(robot_id=1, driver="page-b", take=True)))
    wait_msg(driving, DriveState, lambda s: s.driver == "page-b")  # an explicit takeover


def test_the_committed_trace_drives_slalom_manual_to_pass_and_the_report_shows_the_driving(tmp_path: Path) -> None:
    rec = tmp_path / "manual.mcap"
    argv = iwz_run_argv(
        MAPS / "scenarios" / "slalom-manual.toml",
        tmp_path / "logs",
        "drive",
        record=rec,
        extra=("--lockstep", "--input-trace", str(TRACE)),
    )
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = p.communicate(timeout=250)
    except subprocess.TimeoutExpired:
        out, err = stop_run(p)
        pytest.fail(f"still running after 250 s, stopped:\n{out}{err}")
    assert p.returncode == 0, out + err
    assert "PASS robot 1 within 0.5 m of (20, 6.1)" in out + err
    assert "PASS collisions 0" in out + err
    report = subprocess.run(
        [sys.executable, "-m", "iw_zenoh.cli", "report", str(rec)], capture_output=True, text=True, timeout=120
    )
    assert report.returncode == 0, report.stderr
    rows = {line[:36].strip(): line[36:].strip() for line in report.stdout.splitlines()}
    inputs = sum(1 for line in TRACE.read_text().splitlines() if line.startswith("{"))
    # every replayed input is recorded as a driver's; the run stops once the goal is reached, so
    # the trace's last inputs (its release, after the goal) may not have been given
    assert inputs - 10 <= int(rows["driver inputs"]) <= inputs
    assert int(rows["commands given"]) > 10
    assert rows["assistance intervened, s"] == "0.0"  # slalom-manual: no shared control
    # the next step a user takes: the run as a rosbag2 bag; rosbags' own reader finds the driver's joystick
    bag = tmp_path / "bag"
    export = subprocess.run(
        [sys.executable, "-m", "iw_zenoh.cli", "export", "--ros2", str(rec), "-o", str(bag), "--quiet"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert export.returncode == 0, export.stderr
    from rosbags.rosbag2 import Reader

    from iw_zenoh.ros2 import types as t

    with Reader(bag) as r:
        joy = [c for c in r.connections if c.msgtype == t.JOY]
        assert [c.topic for c in joy] == ["/robot1/joy"]
        pushes = [t.store().deserialize_cdr(d, t.JOY) for _, _, d in r.messages(connections=joy)]
    assert len(pushes) == int(rows["driver inputs"])
    assert any(j.axes[1] > 0.1 and j.buttons[0] == 1 for j in pushes)  # pushed forward, the dead-man held
