"""The serial bridge's rules, without a line: staleness, e-stop latch, link state, odometry."""

from __future__ import annotations

import math

import pytest
from iw_zenoh.bridges.serial.bridge import STALE_S, BridgeCore, WheelOdometry
from iw_zenoh.bridges.serial.protocol import FLAG_ESTOP, FLAG_ESTOP_BOARD, Clear, EStop, Motors, Status


def _core() -> BridgeCore:
    core = BridgeCore(WheelOdometry((1.0, 1.0, 0.0), 0.5, 1000.0))
    core.on_line(True)
    return core


def _status(enc: tuple[int, int] = (0, 0), flags: int = 0) -> Status:
    return Status(ack=0, encoders=enc, wheels=(0, 0), battery_mv=25000, flags=flags)


def test_a_fresh_action_goes_out_in_wire_units() -> None:
    core = _core()
    core.on_action(0.1, -0.05, 0.0)
    assert core.outgoing(STALE_S - 0.01) == Motors(1000, -500)


def test_a_stale_action_goes_out_as_zero() -> None:
    core = _core()
    core.on_action(0.1, 0.1, 0.0)
    assert core.outgoing(STALE_S + 0.01) == Motors(0, 0)


def test_nothing_commanded_yet_is_zero() -> None:
    assert _core().outgoing(0.0) == Motors(0, 0)


def test_an_operator_estop_latches_until_clear_then_waits_for_a_fresh_action() -> None:
    core = _core()
    core.on_estop()
    core.on_action(0.1, 0.1, 1.0)
    assert core.outgoing(1.0) == EStop()
    core.on_clear()
    assert core.outgoing(1.1) == Clear()
    core.on_status(_status(), 1.15)  # the board has cleared
    assert core.outgoing(1.2) == Motors(0, 0)
    core.on_action(0.1, 0.1, 1.3)
    assert core.outgoing(1.3) == Motors(1000, 1000)


def test_the_chairs_own_estop_latches_the_bridge_too() -> None:
    core = _core()
    core.on_action(0.1, 0.1, 0.0)
    core.on_status(_status(flags=FLAG_ESTOP | FLAG_ESTOP_BOARD), 0.05)
    assert core.estop_source == "chair"
    assert core.outgoing(0.06) == EStop()


def test_the_link_is_down_without_status_or_line() -> None:
    core = _core()
    core.on_status(_status(), 0.0)
    assert core.link_up(0.1)
    assert not core.link_up(1.0)
    core.on_line(False)
    assert not core.link_up(0.0)


def test_odometry_integrates_counts_and_wraps_int32() -> None:
    odo = WheelOdometry((0.0, 0.0, 0.0), 0.5, 1000.0)
    odo.update((2**31 - 100, 2**31 - 100))
    x, y, d = odo.update((-(2**31) + 900, -(2**31) + 900))  # both wheels rolled 1000 ticks: 1 m
    assert x == pytest.approx(1.0)
    assert y == pytest.approx(0.0)
    assert d == pytest.approx(0.0)


def test_odometry_turns_on_the_spot() -> None:
    odo = WheelOdometry((0.0, 0.0, 0.0), 0.5, 1000.0)
    odo.update((0, 0))
    _, _, d = odo.update((-int(250 * math.pi / 2), int(250 * math.pi / 2)))
    assert d == pytest.approx(90.0, abs=0.5)


def test_after_the_link_returns_counts_are_a_new_baseline() -> None:
    core = _core()
    core.on_status(_status((0, 0)), 0.0)
    core.on_status(_status((500, 500)), 0.05)
    core.on_line(False)
    core.on_line(True)
    core.on_status(_status((10, 10)), 1.0)  # the board restarted
    assert core.odometry.pose[0] == pytest.approx(1.5)
