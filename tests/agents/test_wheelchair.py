"""The wheelchair agent's parts: teleop over a real pseudo-terminal, merging, the emulated chair."""

from __future__ import annotations

import os
import pty
import subprocess
import sys
import threading
import time
from collections.abc import Iterator

import numpy as np
import pytest
from iw_zenoh.agents.autopilot import mapping_chair
from iw_zenoh.agents.chairlink import SerialChair
from iw_zenoh.agents.emulated import EmulatedChair
from iw_zenoh.agents.passage import Ask, parse_all
from iw_zenoh.agents.teleop import KeyReader, Teleop
from iw_zenoh.agents.wheelchair import Wheelchair, merge_nearer

from iw_zenoh.core.lab import Lab
from iw_zenoh.messages import ChairReading


def test_merging_keeps_the_nearer_reading_of_each_sensor() -> None:
    assert merge_nearer([1.0, None, 0.5, None], [0.8, 2.0, None, None]) == [0.8, 2.0, 0.5, None]


@pytest.fixture
def terminal() -> Iterator[tuple[int, KeyReader]]:
    master, slave = pty.openpty()
    keys = KeyReader(slave)
    t = threading.Thread(target=keys.run, daemon=True)
    t.start()
    assert keys.ready.wait(5.0)
    yield master, keys
    keys.quit.set()
    t.join(timeout=5)
    os.close(master)
    os.close(slave)


def _wait_key(keys: KeyReader, name: str) -> None:
    deadline = time.monotonic() + 5.0
    while keys.last != name and time.monotonic() < deadline:
        keys.quit.wait(0.01)
    assert keys.last == name


def test_arrow_keys_on_a_terminal_drive_and_space_stops(terminal: tuple[int, KeyReader]) -> None:
    master, keys = terminal
    tele = Teleop(keys, limit=0.06, stale_s=10.0)
    os.write(master, b"\x1b[A")
    _wait_key(keys, "up")
    assert tele.command(time.monotonic()) == (0.06, 0.06, "forward")
    os.write(master, b"\x1b[D")
    _wait_key(keys, "left")
    left, right, _ = tele.command(time.monotonic())
    assert left < 0 < right
    os.write(master, b" ")
    _wait_key(keys, "stop")
    assert tele.command(time.monotonic())[:2] == (0.0, 0.0)


def test_plus_and_minus_change_the_speed_limit_within_bounds(terminal: tuple[int, KeyReader]) -> None:
    master, keys = terminal
    tele = Teleop(keys, limit=0.14, stale_s=10.0)
    os.write(master, b"+++")
    deadline = time.monotonic() + 5.0
    while len(keys._pending) < 3 and time.monotonic() < deadline:
        keys.quit.wait(0.01)
    tele.command(time.monotonic())
    assert tele.limit == 0.15  # never above the motors' limit
    os.write(master, b"-\x1b[A")
    _wait_key(keys, "up")
    assert tele.command(time.monotonic())[:2] == (0.14, 0.14)


def test_a_stale_key_stops_the_chair(terminal: tuple[int, KeyReader]) -> None:
    master, keys = terminal
    tele = Teleop(keys, limit=0.06, stale_s=0.5)
    os.write(master, b"\x1b[A")
    _wait_key(keys, "up")
    now = keys.at
    assert tele.command(now + 0.1)[:2] == (0.06, 0.06)
    assert tele.command(now + 0.6) == (0.0, 0.0, "stopped")  # held key not repeated: stop


def test_q_quits_and_unknown_bytes_are_ignored(terminal: tuple[int, KeyReader]) -> None:
    master, keys = terminal
    os.write(master, b"xyz\x1b[Zq")
    assert keys.quit.wait(5.0)
    assert keys.last == "quit"


def test_the_emulated_chair_moves_reports_odometry_and_sees_its_own_room() -> None:
    from tests.support.builders import box_wall

    room = Lab("r", 10.0, 6.0, (box_wall(4.0, 2.0, 5.0, 4.0),))
    hw = EmulatedChair(mapping_chair("c", id=7, x_m=1.0, y_m=3.0, dir_deg=0.0), room, seed=3)
    ahead = [d for i, d in zip(hw.reading.proximity_ids, hw.reading.proximity_m, strict=True) if i == 3][0]
    assert ahead is not None
    assert ahead == pytest.approx(4.0 - 1.0 - 0.8, abs=0.05)
    for _ in range(30):
        hw.drive(0.06, 0.06)
    x, y, _ = hw.pose
    tx, ty, _ = hw.world.pose(1)
    assert x > 1.3
    assert abs(x - tx) < 0.05  # the odometry pose follows the truth (and drifts slowly)
    assert hw.real_collisions == 0


def _agent(*args: str) -> subprocess.CompletedProcess[str]:
    argv = [sys.executable, "-m", "iw_zenoh.cli", "agent", "wheelchair", "--map", "maps/open-room.xml", *args]
    return subprocess.run(argv, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60)


def test_teleop_without_a_terminal_is_refused_with_the_reason() -> None:
    r = _agent("--start", "1,3,0", "--teleop")
    assert r.returncode == 2
    assert "run it in a terminal" in r.stdout


def test_the_wheelchair_needs_a_goal_or_teleop() -> None:
    r = _agent("--start", "1,3,0")
    assert r.returncode == 2
    assert "--goal X,Y" in r.stdout


def test_a_chair_that_has_asked_a_door_keeps_asking_while_it_plans_again() -> None:
    # silent for 3 s, a chair loses its place (or the doorway it holds): a chair stopped to plan
    # again (no path for a moment) must not fall silent
    spec = mapping_chair("c", id=2, x_m=6.0, y_m=3.0, dir_deg=0.0)
    chair = Wheelchair(spec, Lab("room", 12.0, 6.0), goal=(11.0, 3.0), doors=[(1, 8.0, 3.0)])
    chair.on_registered(2, spec)
    chair.pilot.path = np.array([[6.0, 3.0, 0.0], [8.0, 3.0, 0.0], [11.0, 3.0, 0.0]])
    say, _ = chair._negotiate((6.0, 3.0, 0.0), [], 0.0)
    assert say is not None
    assert isinstance(parse_all(say)[0], Ask)
    chair.pilot.path = None  # planning again
    for t in (1.0, 2.0, 3.0, 4.0):
        say, _ = chair._negotiate((6.0, 3.0, 0.0), [], t)
        assert say is not None
        assert isinstance(parse_all(say)[0], Ask)


def test_a_serial_chair_turning_on_the_spot_pairs_the_reading_taken_at_the_worlds_heading() -> None:
    chair = SerialChair((10.0, 6.1, 0.0))
    for k in range(20):  # a second of a turn on the spot: one position, the heading sweeping
        chair.update(ChairReading(robot_id=1, pose=(10.0, 6.1, 2.0 * k), proximity_ids=[0], proximity_m=[1.0 + k]))
    assert chair.taken_at((10.0, 6.1, 20.0)).proximity_m == [11.0]  # not the oldest reading, at 0 degrees
    assert chair.taken_at((10.0, 6.1, 99.0)).proximity_m == [20.0]  # of the nearest, the newest


def test_a_standing_serial_chair_pairs_its_newest_reading() -> None:
    chair = SerialChair((10.0, 6.1, 0.0))
    for d in (3.0, 2.0, 1.0):  # something came nearer while the chair stood still
        chair.update(ChairReading(robot_id=1, pose=(10.0, 6.1, 0.0), proximity_ids=[0], proximity_m=[d]))
    assert chair.taken_at((10.0, 6.1, 0.0)).proximity_m == [1.0]
