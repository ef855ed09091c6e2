"""The serial bridge with real processes: a chair emulator on a real pty, the bridge, the world.

The test plays the agent (it publishes the robot's actions) and watches the chair's wheels in
the emulator's wheel log (monotonic time, shared by every process on this machine).
"""

from __future__ import annotations

import signal
import sys
import time
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.messages import Actions, ChairReading, Control, WorldState, encode
from tests.integration.harness import MAPS, Net, Proc, subscribe, wait_event, wait_msg
from tests.integration.serial_sim import start_sim

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(150)]

STALE_S = 0.2
SLACK_S = 0.15  # scheduling of three processes on a loaded 2-core machine


def start_emulator(net: Net, *extra: str) -> tuple[Proc, str, Path]:
    """``iwz chair emulate --pty`` with a stable link; waits until it prints it."""
    link, wheels = str(net.tmp / "chair-link"), net.tmp / "wheels.log"
    argv = [sys.executable, "-m", "iw_zenoh.cli", "chair", "emulate", "--pty", "--link", link]
    argv += ["--map", str(MAPS / "liacc.xml"), "--start", "10,6.1,0", "--wheels-log", str(wheels), *extra]
    proc = net.launch("emulator", argv)
    deadline = time.monotonic() + 30
    while "chair board on" not in proc.output():
        assert proc.popen.poll() is None, proc.output()
        assert time.monotonic() < deadline, "the emulator made no pty in 30 s"
        time.sleep(0.05)  # polling a log file: there is no event to wait on
    return proc, link, wheels


def drive(bus: ZenohBus, sim: str, power: float, seconds: float) -> int:
    """Publishes actions for robot 1 at 20 Hz for ``seconds``; returns the last one's monotonic ns."""
    last = 0
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        bus.publish(keys.actions(sim, 1), encode(Actions(robot_id=1, left=power, right=power)))
        last = time.monotonic_ns()
        time.sleep(0.05)  # an agent's pace, not synchronisation
    return last


def wheel_changes(path: Path) -> list[tuple[int, int, int]]:
    """(monotonic ns, left, right) of every wheel change the emulator logged."""
    if not path.exists():
        return []
    return [(int(a), int(b), int(c)) for a, b, c in (ln.split() for ln in path.read_text().splitlines())]


def test_a_stale_agent_stops_the_chairs_wheels_within_200_ms(net: Net) -> None:
    _, link, wheels = start_emulator(net)
    bus = start_sim(net, link)
    chair = subscribe(bus, keys.chair(net.sim, 1))
    wait_msg(chair, ChairReading, lambda r: r.link == "up", timeout_s=60)
    last_ns = drive(bus, net.sim, 0.1, 1.5)
    # the readings queued since the link came up: the chair's wheels at the command, then still
    # where it went (not a reading from before the command reached it, still at its start)
    moving = wait_msg(chair, ChairReading, lambda r: r.wheels == (0.1, 0.1), 5)
    stopped = wait_msg(chair, ChairReading, lambda r: r.wheels == (0.0, 0.0) and r.pose[0] > 10.05, 5)
    assert stopped.pose[0] > 10.05  # it moved, by its own odometry
    changes = wheel_changes(wheels)
    assert (1000, 1000) in [(lw, rw) for _, lw, rw in changes], changes
    zero_ns = next(t for t, lw, rw in changes if (lw, rw) == (0, 0) and t > last_ns - 10**8)
    assert (zero_ns - last_ns) / 1e9 <= STALE_S + SLACK_S
    assert moving is not None


def test_unplug_and_replug_mid_run_and_the_run_goes_on(net: Net) -> None:
    emu, link, wheels = start_emulator(net, "--fault", "unplug")
    bus = start_sim(net, link)
    events = subscribe(bus, keys.all_events(net.sim))
    state = subscribe(bus, keys.state(net.sim), maxlen=1)
    chair = subscribe(bus, keys.chair(net.sim, 1))
    wait_msg(chair, ChairReading, lambda r: r.link == "up", timeout_s=60)
    for _ in range(20):  # until the world has moved it: its robot may join a moment after the link is up
        drive(bus, net.sim, 0.08, 0.5)
        moving = wait_msg(state, WorldState, lambda s: 1 in s.ids, 5)
        if moving.x[moving.ids.index(1)] > 10.0:
            break
    emu.popen.send_signal(signal.SIGUSR1)  # pull the cable
    wait_event(events, "serial-link-lost", timeout_s=10)
    held = wait_msg(state, WorldState, lambda s: 1 in s.ids, 5)
    assert held.x[held.ids.index(1)] > 10.0  # the robot is held in the world
    emu.popen.send_signal(signal.SIGUSR1)  # and plug it back
    wait_event(events, "serial-link", timeout_s=10)
    chair.drain()  # the readings queued since the start: the pose is the one now, plugged back
    before = wait_msg(chair, ChairReading, lambda r: r.link == "up", 5).pose[0]
    drive(bus, net.sim, 0.1, 1.0)
    wait_msg(chair, ChairReading, lambda r: r.wheels == (0.1, 0.1), 5)  # the commands reached the chair
    after = wait_msg(chair, ChairReading, lambda r: r.wheels == (0.0, 0.0) and r.pose[0] > before + 0.02, 5).pose[0]
    assert after > before + 0.02  # commands reach the chair again, no restart
    assert net.procs[-1].popen.poll() is None  # the bridge is still the same process


def test_corrupted_bytes_are_dropped_and_never_move_the_chair(net: Net) -> None:
    _, link, wheels = start_emulator(
        net, "--fault", "flip", "--fault-rate", "0.02", "--fault-at", "0", "--fault-for", "1e9"
    )
    bus = start_sim(net, link)
    chair = subscribe(bus, keys.chair(net.sim, 1))
    wait_msg(chair, ChairReading, lambda r: r.link == "up", timeout_s=60)
    drive(bus, net.sim, 0.0, 2.0)  # zero commands, mangled on the way: a flipped bit must not become a speed
    last = wait_msg(chair, ChairReading, lambda r: r.dropped > 0, 5)
    assert last.frames > 0
    assert wheel_changes(wheels) == []
    assert abs(last.pose[0] - 10.0) < 1e-9


def test_an_augmented_wheelchair_drives_the_emulated_chair_through_the_serial_link(net: Net) -> None:
    _, link, _ = start_emulator(net)
    bus = start_sim(net, link)
    state = subscribe(bus, keys.state(net.sim), maxlen=1)
    chair = subscribe(bus, keys.chair(net.sim, 1))
    wait_msg(chair, ChairReading, lambda r: r.link == "up", timeout_s=60)
    net.spawn(
        "agent", "wheelchair", "--chair", "augmented", "--hardware", "serial", "--id", "1",
        "--map", str(MAPS / "liacc.xml"), "--start", "10,6.1,0", "--goal", "12,6.1",
    )  # fmt: skip
    there = wait_msg(state, WorldState, lambda s: 1 in s.ids and s.x[s.ids.index(1)] > 11.5, timeout_s=90)
    assert abs(there.y[there.ids.index(1)] - 6.1) < 0.5
    chair.drain()
    own = wait_msg(chair, ChairReading, lambda r: r.link == "up", 5)
    assert own.pose[0] > 11.0  # the world's pose is the chair's own odometry
    assert any(d is not None for d in own.proximity_m)


def test_an_operator_estop_latches_until_cleared(net: Net) -> None:
    _, link, wheels = start_emulator(net)
    bus = start_sim(net, link)
    chair = subscribe(bus, keys.chair(net.sim, 1))
    wait_msg(chair, ChairReading, lambda r: r.link == "up", timeout_s=60)
    bus.publish(keys.control(net.sim), encode(Control(command="estop", robot_id=1)))
    wait_msg(chair, ChairReading, lambda r: r.estop, 5)
    drive(bus, net.sim, 0.1, 1.0)  # commands while latched do nothing
    assert wheel_changes(wheels) == []
    bus.publish(keys.control(net.sim), encode(Control(command="clear", robot_id=1)))
    wait_msg(chair, ChairReading, lambda r: not r.estop, 5)
    drive(bus, net.sim, 0.1, 0.5)
    deadline = time.monotonic() + 10  # the last commands may still be on their way to the chair
    while (1000, 1000) not in [(lw, rw) for _, lw, rw in wheel_changes(wheels)]:
        assert time.monotonic() < deadline, wheel_changes(wheels)
        time.sleep(0.05)  # polling a log file: there is no event to wait on


def test_a_bridge_whose_device_is_not_there_says_so(net: Net) -> None:
    """A wrong --port (or a chair not plugged in) was said only at debug level: the bridge
    registered its robot and printed nothing else, holding it still for ever. It says once,
    with the device's error, that it keeps trying and what to check."""
    net.spawn("world", str(MAPS / "liacc.xml"), "--grid", str(MAPS / "liacc-grid.xml"))
    gone = str(net.tmp / "no-such-tty")
    bridge = net.spawn("bridge", "serial", "--port", gone, "--robot", "chair", "--id", "1", "--start", "10,6.1,0")
    deadline = time.monotonic() + 30
    while "is --port its device?" not in bridge.output() or "is robot 1" not in bridge.output():
        assert bridge.popen.poll() is None, bridge.output()
        assert time.monotonic() < deadline, f"nothing said of the missing device:\n{bridge.output()}"
        time.sleep(0.05)  # polling a log file: there is no event to wait on
    said = bridge.output()
    assert gone in said
    assert said.count("is --port its device?") == 1  # once, not at every retry while it registered
