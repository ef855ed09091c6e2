"""A tick's Measures carry that tick's says: readings wait for the radio's hear lists of their
tick (while a radio is alive), a stopped simulator's says are heard in its stopped Measures, and
what misses its cycle is counted, never heard a cycle late (bridges/ciberrato/hearing.py)."""

from __future__ import annotations

from iw_zenoh.bridges.ciberrato.hearing import LOCKSTEP_WAIT_NS, Hearing
from iw_zenoh.bridges.ciberrato.robot import LegacyRobot

from iw_zenoh.core.params import SimParameters
from iw_zenoh.messages import Hear, Heard, RadioBatch, SensorBatch, SensorReading

MS = 1_000_000


def _batch(tick: int) -> SensorBatch:
    reading = SensorReading(
        tick=tick,
        robot_id=1,
        proximity_ids=[0, 1, 2, 3],
        proximity_m=[None] * 4,
        proximity_legacy=[1.0] * 4,
        compass_deg=0.0,
        gps=(0.0, 0.0, 0.0),
        ground=-1,
    )
    return SensorBatch(tick=tick, shard="1/1", readings=[reading])


def _radio(tick: int, text: str) -> RadioBatch:
    heard = [Heard(sender=2, distance_m=1.0, text=text)]
    return RadioBatch(tick=tick, hear=[Hear(tick=tick, robot_id=1, messages=heard)])


def test_with_a_radio_alive_readings_wait_for_their_ticks_hear_lists() -> None:
    h = Hearing()
    assert h.ready([_batch(1)], None, 0) == [_batch(1)]  # no radio: nothing waits
    h.on_alive("radio", True)
    assert h.ready([_batch(2)], None, 0) == []
    robots = {1: LegacyRobot(1)}
    h.take([_radio(2, "two")], robots)
    assert h.ready([], None, 1) == [_batch(2)]
    assert robots[1].heard == {2: [(2, "two")]}
    assert h.late == []


def test_readings_whose_hear_lists_do_not_come_go_at_the_deadline_and_are_told() -> None:
    h = Hearing()
    h.on_alive("radio", True)
    assert h.ready([_batch(5)], None, 0) == []
    assert h.ready([], None, LOCKSTEP_WAIT_NS - 1) == []
    assert h.ready([], None, LOCKSTEP_WAIT_NS) == [_batch(5)]
    assert h.late == [5]
    robots = {1: LegacyRobot(1)}
    h.take([_radio(5, "late")], robots)  # after its Measures: dropped then, never heard at tick 6
    robot = robots[1]
    robot.reading = _batch(6).readings[0]
    data = robot.next_measures(6, SimParameters(), running=True)
    assert data is not None
    assert b"late" not in data
    assert robot.missed == 1
    n, why = h.missed(robots, 10.0)
    assert n == 1
    assert "[5]" in why
    assert h.missed(robots, 10.5) == (0, "")  # told at most once a second


def test_a_radio_gone_lets_the_readings_go_at_once() -> None:
    h = Hearing()
    h.on_alive("radio", True)
    assert h.ready([_batch(1)], None, 0) == []
    h.on_alive("radio", False)
    assert h.ready([], None, 1) == [_batch(1)]


def test_says_of_a_stopped_cycle_reach_the_robots_strictly_within_8_speaker_included() -> None:
    robots = {rid: LegacyRobot(rid, pose=(x, 1.0)) for rid, x in ((1, 1.0), (2, 8.99), (3, 9.0))}
    h = Hearing()
    h.stopped_says = {2: "b", 1: "a"}
    h.stopped(0, robots)
    assert robots[1].heard[0] == [(1, "a"), (2, "b")]
    assert robots[2].heard[0] == [(1, "a"), (2, "b")]
    assert robots[3].heard[0] == [(2, "b")]  # 8.0 from robot 1: not heard; 0.01 from robot 2
    assert h.stopped_says == {}
    data = robots[1].next_measures(0, SimParameters(), running=False, force=True)  # no reading yet
    assert data is not None
    assert b'<Message From="1"><![CDATA[a]]></Message>\n\t\t<Message From="2"><![CDATA[b]]></Message>' in data
