"""The serial bridge refuses a Status the chair cannot have sent (issue 33): encoder steps beyond
its top speed, a battery outside 8-40 V, a range beyond 20 m; the odometry never jumps, the chair
is held while it persists, and no value a board sends raises."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from bridges.serial.bridge import HOLD_AFTER_S, BridgeCore, WheelOdometry
from bridges.serial.protocol import NO_RANGE, Motors, Status

INT32 = st.integers(-(2**31), 2**31 - 1)


def _core() -> BridgeCore:
    core = BridgeCore(WheelOdometry((10.0, 6.0, 0.0), 0.5, 2000.0), max_speed_mps=0.5)
    core.on_line(True)
    core.on_action(0.1, 0.1, 0.0)
    return core


def _status(left: int, right: int, battery_mv: int = 25_000, ranges: tuple[int, ...] = ()) -> Status:
    return Status(ack=0, encoders=(left, right), wheels=(0, 0), battery_mv=battery_mv, ranges_mm=ranges)


def test_counts_jumping_2_31_a_frame_are_refused_and_the_odometry_stays() -> None:
    core, c = _core(), 0
    assert core.on_status(_status(0, 0), 0.0) == ("", "")
    for k in range(1, 40):
        c = (c + 2**31 - 1 + 2**31) % 2**32 - 2**31
        what, why = core.on_status(_status(c, c), k * 0.05)
        assert what == "encoders", why
        assert "beyond the chair's top speed" in why
    assert core.odometry.pose == (10.0, 6.0, 0.0)
    assert core.held(39 * 0.05)
    assert core.outgoing(39 * 0.05) == Motors(0, 0)
    assert core.on_status(_status(c + 50, c + 50), 40 * 0.05) == ("", "")  # plausible again: driven
    assert not core.held(40 * 0.05)
    assert core.odometry.pose[0] > 10.0


def test_a_real_wrap_of_the_counts_is_a_small_step() -> None:
    core = _core()
    core.on_status(_status(2**31 - 10, 2**31 - 10), 0.0)
    assert core.on_status(_status(-(2**31) + 10, -(2**31) + 10), 0.05) == ("", "")
    assert math.isclose(core.odometry.pose[0], 10.01)


def test_a_dead_battery_or_a_range_of_60_m_is_refused_and_holds_the_chair_if_it_persists() -> None:
    core = _core()
    core.on_status(_status(0, 0), 0.0)
    assert core.on_status(_status(10, 10, battery_mv=0), 0.05)[0] == "battery"
    assert not core.held(0.05)  # once is not yet a hold
    assert core.on_status(_status(10, 10, ranges=(60_000,)), 0.05 + HOLD_AFTER_S)[0] == "ranges"
    assert core.held(0.05 + HOLD_AFTER_S)
    assert core.on_status(_status(10, 10, ranges=(NO_RANGE, 1500)), 0.1 + HOLD_AFTER_S) == ("", "")
    assert not core.held(0.1 + HOLD_AFTER_S)


@given(
    st.lists(st.tuples(INT32, INT32, st.integers(0, 65535), st.lists(st.integers(0, 65535), max_size=4)), max_size=60)
)
def test_no_status_a_board_sends_raises_or_moves_the_chair_faster_than_it_can(frames: list) -> None:  # type: ignore[type-arg]
    core = _core()
    for k, (left, right, battery, ranges) in enumerate(frames):
        core.on_status(_status(left, right, battery, tuple(ranges)), k * 0.05)
        x, y, _ = core.odometry.pose
        assert math.hypot(x - 10.0, y - 6.0) <= (k + 1) * (0.5 * 2 * 0.1 + 0.05) + 1e-9
