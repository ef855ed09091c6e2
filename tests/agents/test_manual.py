"""The manual chair (agents/manual.py, agents/seat.py) on the whole tick in one process
(LocalWorld): shared control at a wall and at a doorway, the dead-man, one driver, traces
(tests/integration/test_driving.py replays the committed slalom trace through real processes)."""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from iw_zenoh.agents import wheelchair
from iw_zenoh.agents.manual import ManualChair, load_trace
from iw_zenoh.agents.mapping_chair import mapping_chair
from iw_zenoh.agents.seat import DriverSeat
from iw_zenoh.agents.teleop import KeyReader, Teleop
from iw_zenoh.agents.wheelchair import Wheelchair

from iw_zenoh.core.lab import Lab, Wall
from iw_zenoh.messages import DriveInput
from iw_zenoh.sim.local import LocalWorld


def _box(x0: float, y0: float, x1: float, y1: float) -> Wall:
    return Wall(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), 2.0)


def _push(lab: Lab, start: tuple[float, float], assist: str, level: int, ticks: int) -> tuple[LocalWorld, bool]:
    """A full push forward (dead-man held) for ``ticks`` ticks; the world and whether it collided."""
    w = LocalWorld(lab, seed=1)
    rid = w.add(mapping_chair("m", id=1, x_m=start[0], y_m=start[1], dir_deg=0.0))
    chair = ManualChair(w.spec(rid), assist=assist, clock=lambda: 0.0)
    chair.on_registered(rid, w.spec(rid))
    s, hit = w.step({}), False
    for k in range(ticks):
        chair.on_drive(DriveInput(robot_id=rid, driver="p", seq=k, y=1.0, buttons=1, level=level))
        s = w.step({rid: chair.on_sensors(s.readings[rid], [])})
        hit = hit or s.readings[rid].collision
    return w, hit


FRONT_M = 0.81 * 1.04  # the chair's front, ahead of its centre of movement
WALL = Lab("wall", 10.0, 6.0, (_box(6.0, 1.0, 6.2, 5.0),))


@pytest.mark.parametrize("level", [1, 2, 3, 4, 5])
def test_safe_stops_a_full_push_into_a_wall_from_2_m_short_of_it(level: int) -> None:
    w, hit = _push(WALL, (6.0 - 2.0 - FRONT_M, 3.0), "safe", level, 250)
    st = w.state
    assert st is not None
    assert not hit
    assert 6.0 - (st.x[0] + FRONT_M) >= 0.05  # at least 5 cm of clearance
    assert st.speed[0] == pytest.approx(0.0, abs=1e-3)


def test_without_shared_control_the_same_push_hits_the_wall() -> None:
    _, hit = _push(WALL, (6.0 - 2.0 - FRONT_M, 3.0), "off", 5, 100)
    assert hit


DOOR = Lab("door", 12.0, 6.0, (_box(6.0, 0.0, 6.2, 2.5), _box(6.0, 3.5, 6.2, 6.0)))  # a 1 m doorway at y 2.5..3.5


@pytest.mark.parametrize("offset", [0.3, -0.35])
def test_assist_takes_a_straight_push_at_a_doorways_edge_through_it(offset: float) -> None:
    # the chair (0.66 m across) pushed straight at y = 3 + offset would hit a jamb
    w, hit = _push(DOOR, (3.0, 3.0 + offset), "assist", 3, 150)
    st = w.state
    assert st is not None
    assert not hit
    assert st.x[0] - 0.2 > 6.2  # its rear is past the wall: through


def test_without_assist_the_push_at_the_edge_does_not_pass() -> None:
    w, hit = _push(DOOR, (3.0, 3.3), "safe", 3, 150)
    assert w.state is not None
    assert w.state.x[0] < 6.0
    assert not hit


def test_the_dead_man_zeroes_the_command_300_ms_after_the_last_input() -> None:
    now = [0.0]
    w = LocalWorld(Lab("open", 20.0, 10.0), seed=1)
    rid = w.add(mapping_chair("m", id=1, x_m=3.0, y_m=5.0, dir_deg=0.0))
    chair = ManualChair(w.spec(rid), clock=lambda: now[0])
    chair.on_registered(rid, w.spec(rid))
    s = w.step({})
    for k in range(20):  # 2 s of a held push, input every tick
        now[0] = k * 0.1
        chair.on_drive(DriveInput(robot_id=rid, driver="p", seq=k, y=1.0, buttons=1, level=5))
        cmd = chair.on_sensors(s.readings[rid], [])
        s = w.step({rid: cmd})
    assert cmd.left > 0
    assert chair.state is not None
    assert not chair.state.stale
    now[0] += 0.25  # no input: still within the dead-man's 300 ms
    assert chair.on_sensors(s.readings[rid], []).left > 0
    now[0] += 0.1
    cmd = chair.on_sensors(s.readings[rid], [])
    assert (cmd.left, cmd.right) == (0.0, 0.0)
    assert chair.state is not None
    assert chair.state.stale
    assert chair.state.v_mps == 0.0


def test_the_stick_counts_only_while_the_dead_man_button_is_held() -> None:
    seat = DriverSeat(1)
    seat.offer(DriveInput(robot_id=1, driver="p", y=1.0, buttons=0), 0.0)
    assert (seat.stick(0.1).x, seat.stick(0.1).y) == (0.0, 0.0)
    seat.offer(DriveInput(robot_id=1, driver="p", y=1.0, buttons=1), 0.2)
    assert seat.stick(0.3).y == 1.0


def test_one_driver_at_a_time_and_taking_over_is_explicit() -> None:
    seat = DriverSeat(1)
    assert seat.offer(DriveInput(robot_id=1, driver="a", y=0.5, buttons=1), 0.0)
    assert not seat.offer(DriveInput(robot_id=1, driver="b", y=-1.0, buttons=1), 0.1)
    assert seat.driver == "a"
    assert seat.refused == "b"
    assert seat.stick(0.1).y == 0.5
    assert not seat.offer(DriveInput(robot_id=1, driver="b", release=True), 0.1)  # b cannot free a's chair
    assert seat.offer(DriveInput(robot_id=1, driver="b", take=True, y=-1.0, buttons=1), 0.2)
    assert seat.driver == "b"
    assert seat.stick(0.2).y == -1.0
    assert seat.offer(DriveInput(robot_id=1, driver="b", release=True), 0.3)
    assert seat.driver == ""
    assert seat.offer(DriveInput(robot_id=1, driver="a"), 0.4)
    assert not seat.offer(DriveInput(robot_id=2, driver="a"), 0.4)  # another chair's input


def test_a_go_there_goal_ends_when_the_driver_takes_the_stick_again() -> None:
    seat = DriverSeat(1)
    seat.offer(DriveInput(robot_id=1, driver="a", goto=(5.0, 5.0)), 0.0)
    assert seat.goal == (5.0, 5.0)
    seat.offer(DriveInput(robot_id=1, driver="a"), 0.1)
    assert seat.goal == (5.0, 5.0)
    seat.offer(DriveInput(robot_id=1, driver="a", y=0.8, buttons=1), 0.2)
    assert seat.goal is None


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ('{"robot_id": 1}\n', "line 1: iw.DriveInput/1: Object missing required field `driver`"),
        ('{"robot_id": 1, "driver": "a", "x": 3}\n', "line 1: iw.DriveInput/1"),
        ('# c\n{"robot_id":1,"driver":"a","sim_time_ns":5}\n{"robot_id":1,"driver":"a","sim_time_ns":4}\n', "line 3"),
    ],
)
def test_a_bad_trace_is_refused_naming_the_line(tmp_path: Path, text: str, why: str) -> None:
    f = tmp_path / "t.jsonl"
    f.write_text(text)
    with pytest.raises(ValueError, match=why.replace("`", ".")):
        load_trace(f)
    with pytest.raises(ValueError, match="No such file"):
        load_trace(tmp_path / "missing.jsonl")


def test_the_terminal_teleop_with_safe_stops_short_of_a_wall() -> None:
    keys = KeyReader(-1)
    w = LocalWorld(WALL, seed=1)
    rid = w.add(mapping_chair("m", id=1, x_m=6.0 - 1.0 - FRONT_M, y_m=3.0, dir_deg=0.0))
    chair = Wheelchair(w.spec(rid), WALL, goal=None, teleop=Teleop(keys, limit=0.15, stale_s=5.0), assist="safe")
    s, hit = w.step({}), False
    for _ in range(120):
        keys.feed(b"\x1b[A")  # the up arrow, held
        s = w.step({rid: chair.on_sensors(s.readings[rid], [])})
        hit = hit or s.readings[rid].collision
    assert w.state is not None
    assert not hit
    assert 6.0 - (w.state.x[0] + FRONT_M) >= 0.05


def test_the_wheelchairs_page_teleop_is_a_chair_that_takes_a_driver() -> None:
    p = argparse.ArgumentParser()
    wheelchair.add_arguments(p)
    agents = wheelchair.make(p.parse_args(["--map", "maps/open-room.xml", "--start", "1,3,0", "--teleop", "page"]))
    assert isinstance(agents[0], ManualChair)
    assert callable(agents[0].on_drive)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.one_of(st.binary(max_size=60), st.text(max_size=60).map(str.encode)), max_size=5))
def test_any_trace_file_loads_or_is_refused_with_its_line(lines: list[bytes]) -> None:
    with tempfile.TemporaryDirectory() as d:
        f = Path(d) / "t.jsonl"
        f.write_bytes(b"\n".join(line.replace(b"\n", b" ") for line in lines))
        why = ""
        try:
            trace = load_trace(f)
        except ValueError as e:
            why, trace = str(e), []
        assert not why or why.startswith(f"--input-trace {f}")  # refused, saying which file (and line)
        assert all(isinstance(m, DriveInput) for m in trace)
