"""A legacy robot's state (motors, LEDs, request rules, latency queues, Measures) against the
golden captures: fed a captured session's Actions and the sensor values its Measures imply, it
assembles those Measures again, byte for byte."""

from __future__ import annotations

from dataclasses import replace

import pytest
from iw_zenoh.bridges.ciberrato.codec import ActionsFrame, build_measures, parse_actions
from iw_zenoh.bridges.ciberrato.robot import GPS_OFFSET, LegacyRobot
from lxml import etree

from iw_zenoh.core.params import SimParameters
from iw_zenoh.messages import SensorReading
from tests.support.captures import robot_session


def _reading(measures: bytes, tick: int) -> SensorReading:
    """The world's readings that a captured Measures implies."""
    root = etree.fromstring(measures.rstrip(b"\x00"))
    sensors = root.find("Sensors")
    assert sensors is not None
    ir = {int(e.get("Id")): float(e.get("Value")) for e in sensors.iter("IRSensor")}
    beacons = {int(e.get("Id")): e.get("Value") for e in sensors.iter("BeaconSensor")}
    gps = sensors.find("GPS")
    x, y = (float(gps.get("X")) - GPS_OFFSET[0], float(gps.get("Y")) - GPS_OFFSET[1]) if gps is not None else (0, 0)
    return SensorReading(
        tick=tick,
        robot_id=1,
        proximity_ids=list(ir),
        proximity_m=[None] * len(ir),
        proximity_legacy=[ir[i] for i in sorted(ir)],
        compass_deg=float(sensors.get("Compass", "0")),
        beacons_deg=[None if v == "NotVisible" else float(v) for _, v in sorted(beacons.items())],
        gps=(x, y, 0.0),
        ground=int(sensors.get("Ground", "-1")),
        collision=sensors.get("Collision") == "Yes",
    )


def _replay(capture: str) -> list[tuple[bytes, bytes]]:
    """(captured, assembled) Measures of a capture's first robot, in order."""
    params, n_beacons, session = robot_session(capture)
    robot = LegacyRobot(1, name="bot1", n_beacons=n_beacons)
    out = []
    for g in session:
        if g.to_server:
            robot.on_actions(parse_actions(g.data))
            continue
        root = etree.fromstring(g.data.rstrip(b"\x00"))
        tick = int(root.get("Time"))
        buttons = root.find("Buttons")
        assert buttons is not None
        robot.reading = _reading(g.data, tick)
        built = robot.next_measures(tick, params, running=buttons.get("Start") == "On", force=True)
        assert built is not None
        out.append((g.data, built))
    return out


@pytest.mark.parametrize("capture", ["robsample_viewer_C1.txt", "gps_beacon_compass_C1.txt", "nbots_refused_C1.txt"])
def test_a_captured_sessions_measures_are_assembled_byte_for_byte(capture: str) -> None:
    pairs = _replay(capture)
    assert len(pairs) >= 30
    for captured, built in pairs:
        assert built == captured


def test_leds_set_in_actions_show_in_the_next_measures_as_the_capture_has_them() -> None:
    pairs = _replay("robsample_viewer_C1.txt")
    leds = [etree.fromstring(b.rstrip(b"\x00")).find("Leds").attrib for _, b in pairs]
    assert any(d["VisitingLed"] == "On" for d in leds)
    assert any(d["ReturningLed"] == "On" for d in leds)


def test_motors_and_leds_not_given_keep_their_last_value() -> None:
    robot = LegacyRobot(1)
    robot.on_actions(ActionsFrame(left=0.1, right=0.05, leds={"VisitingLed": True}))
    cmd = robot.on_actions(ActionsFrame(right=0.02))
    assert (cmd.left, cmd.right, cmd.visiting_led) == (0.1, 0.02, True)


def test_end_led_finishes_the_robot_and_it_never_moves_again() -> None:
    robot = LegacyRobot(1)
    robot.on_actions(ActionsFrame(left=0.1, right=0.1, leds={"EndLed": True}))
    cmd = robot.on_actions(ActionsFrame(left=0.1, right=0.1, leds={"EndLed": False}))
    assert robot.finished
    assert (cmd.left, cmd.right) == (0.0, 0.0)


def test_once_the_simulation_is_finished_no_robot_moves_and_time_is_frozen() -> None:
    robot = LegacyRobot(1)
    cmd = robot.on_actions(ActionsFrame(left=0.1, right=0.1), sim_finished=True)
    assert (cmd.left, cmd.right) == (0.0, 0.0)
    m = robot.measures(120, SimParameters(), running=False, finished_at=100)
    assert (m.time, m.buttons) == (100, (False, False))


def test_radio_message_and_pose_pass_through_in_the_command() -> None:
    cmd = LegacyRobot(1).on_actions(ActionsFrame(say="hi", pose=(1.0, 2.0, 90.0)))
    assert cmd.say == "hi"
    assert cmd.pose == (1.0, 2.0, 90.0)


def _reading_at(tick: int, ir: float, compass: float = 0.0) -> SensorReading:
    return SensorReading(
        tick=tick,
        robot_id=1,
        proximity_ids=[0, 1, 2, 3],
        proximity_m=[None] * 4,
        proximity_legacy=[ir] * 4,
        compass_deg=compass,
        gps=(0.0, 0.0, 0.0),
        ground=-1,
    )


def test_requestable_sensors_are_sent_only_when_requested_within_the_limit() -> None:
    p = replace(SimParameters(), n_requests_per_cycle=2, obstacle_requestable=True, compass_requestable=True)
    robot = LegacyRobot(1)
    robot.reading = _reading_at(1, 1.5, compass=10.0)
    robot.on_actions(ActionsFrame(requests=("IRSensor0", "IRSensor2")))
    robot.on_actions(ActionsFrame(requests=("Compass",)))  # a third request: over the limit
    m = robot.measures(1, p, running=True)
    assert m.ir == (1.5, None, 1.5, None)
    assert m.compass is None
    assert robot.measures(2, p, running=True).ir == (None,) * 4  # requests last one cycle


def test_latency_delays_a_reading_by_that_many_cycles_with_no_measurement_first() -> None:
    p = replace(SimParameters(), obstacle_latency=2)
    robot = LegacyRobot(1)
    seen = []
    for tick in range(4):
        robot.reading = _reading_at(tick, float(tick + 1))
        seen.append(robot.measures(tick, p, running=True).ir[0])
    assert seen == [0.0, 0.0, 1.0, 2.0]


def test_measures_go_once_a_tick_unless_forced_and_deliver_what_was_heard() -> None:
    p = SimParameters()
    robot = LegacyRobot(1)
    robot.reading = _reading_at(3, 1.0)
    robot.heard = {3: [(2, "hello")]}
    first = robot.next_measures(3, p, running=True)
    assert first is not None
    assert b"hello" in first
    assert robot.next_measures(3, p, running=True) is None
    again = robot.next_measures(3, p, running=True, force=True)
    assert again is not None
    assert b"hello" not in again


def test_before_any_reading_the_measures_hold_no_measurement() -> None:
    m = LegacyRobot(1).measures(0, SimParameters(), running=False)
    assert build_measures(m).startswith(b'<Measures Time="0">\n\t<Sensors Collision="No">')
