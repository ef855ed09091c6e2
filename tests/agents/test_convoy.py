from __future__ import annotations

from iw_zenoh.agents.convoy import Follower, parse_position, say_position
from iw_zenoh.agents.waypoint import fine_chair

from iw_zenoh.messages import Heard, SensorReading


def _reading(x: float, y: float, hdg: float = 0.0) -> SensorReading:
    return SensorReading(
        robot_id=2,
        proximity_ids=list(range(8)),
        proximity_m=[None] * 8,
        proximity_legacy=[100.0] * 8,
        compass_deg=hdg,
        gps=(x, y, hdg),
    )


def test_position_messages_fit_the_radio_and_read_back() -> None:
    text = say_position(12, 123.456, -7.0)
    assert len(text.encode()) <= 100
    assert parse_position(text) == (12, 123.46, -7.0)
    assert parse_position("hello") is None
    assert parse_position("P x 1 2") is None


def test_a_follower_closes_a_long_gap_and_holds_a_short_one() -> None:
    f = Follower(fine_chair("f"), follow_id=1, gap_m=2.0)
    f.robot_id = 2
    far = f.on_sensors(_reading(0.0, 0.0), [Heard(sender=1, distance_m=5.0, text=say_position(1, 5.0, 0.0))])
    assert far.left > 0.1
    assert far.right > 0.1
    near = f.on_sensors(_reading(3.5, 0.0), [Heard(sender=1, distance_m=1.5, text=say_position(1, 5.0, 0.0))])
    assert (near.left, near.right) == (0.0, 0.0)
    assert near.say == say_position(2, 3.5, 0.0)


def test_a_follower_that_hears_nothing_stops() -> None:
    f = Follower(fine_chair("f"), follow_id=1)
    f.on_sensors(_reading(0.0, 0.0), [Heard(sender=1, distance_m=5.0, text=say_position(1, 5.0, 0.0))])
    for _ in range(11):
        cmd = f.on_sensors(_reading(0.0, 0.0), [])
    assert (cmd.left, cmd.right) == (0.0, 0.0)
