"""A person's driving measured from the drive channels (iw_zenoh/record/drive_metrics.py)."""

from __future__ import annotations

import pytest

from iw_zenoh.messages import DriveInput, DriveState
from iw_zenoh.record.drive_metrics import DriveMeter, sector


def _in(x: float, y: float, buttons: int = 1, **kw: object) -> DriveInput:
    return DriveInput(robot_id=1, driver="p", x=x, y=y, buttons=buttons, **kw)  # type: ignore[arg-type]


def test_a_command_is_a_push_into_a_new_direction_a_goal_or_a_level_change() -> None:
    m = DriveMeter()
    for msg in [
        _in(0, 1),  # forward: 1
        _in(0, 0.9),  # still forward
        _in(0, 0),  # centred
        _in(0, 1),  # forward again: 2
        _in(0.8, 0.1),  # right: 3
        _in(0.8, 0.1, buttons=0),  # dead-man released: centred
        _in(0, 0, goto=(3.0, 4.0)),  # go there: 4
        _in(0, 0, level=3),  # a level change: 5
    ]:
        m.on_input(msg)
    f = m.figures(1)
    assert f is not None
    assert (f.inputs, f.commands) == (8, 5)
    assert m.figures(2) is None  # a chair nobody drove


def test_the_time_assistance_intervened_counts_each_state_to_the_next() -> None:
    m = DriveMeter()
    for tick, changed in enumerate([False, True, True, False, True, True]):
        m.on_state(DriveState(robot_id=1, tick=tick, sim_time_ns=tick * 100_000_000, intervened=changed))
    m.on_state(DriveState(robot_id=1, tick=9, sim_time_ns=100 * 100_000_000))  # a gap: at most 0.5 s
    f = m.figures(1)
    assert f is not None
    assert f.intervened_s == pytest.approx(0.2 + 0.1 + 0.5)
    assert f.intervened_ticks == 4


def test_sectors_are_counter_clockwise_from_forward() -> None:
    assert [sector(_in(x, y)) for x, y in [(0, 1), (-1, 0), (0, -1), (1, 0), (0.05, 0.05)]] == [0, 2, 4, 6, -1]


def test_a_tick_answered_again_between_ticks_counts_as_its_last_answer() -> None:
    # agents/manual.py answers an input between ticks with the tick's own time: the world applies
    # the last answer, so the last one says whether shared control stepped in over that tick
    m = DriveMeter()
    for tick, said in [(0, [False]), (1, [False, True]), (2, [False])]:
        for changed in said:
            m.on_state(DriveState(robot_id=1, tick=tick, sim_time_ns=tick * 100_000_000, intervened=changed))
    f = m.figures(1)
    assert f is not None
    assert f.intervened_ticks == 1  # tick 1 only
    assert f.intervened_s == pytest.approx(0.1)
