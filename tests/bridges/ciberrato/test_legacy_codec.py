"""The legacy codec against datagrams captured from the real Ciber-Rato simulator (golden data)."""

from __future__ import annotations

import ast
import contextlib
import re
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from iw_zenoh.bridges.ciberrato.codec import (
    Measures,
    Score,
    build_measures,
    build_robot_state,
    parse_actions,
    parse_viewer_command,
)
from iw_zenoh.bridges.ciberrato.registration import build_refusal, build_reply, parse_registration, registration_spec
from lxml import etree

from iw_zenoh.core.spec import BodyShape, RobotType
from iw_zenoh.errors import ProtocolError, SpecError
from iw_zenoh.maps import load_parameters

CAPTURES = Path(__file__).resolve().parents[2] / "data" / "legacy"  # copied from shared/reference/captures
MAPS = Path(__file__).resolve().parents[3] / "maps"
LINE = re.compile(r"^\s*([\d.]+) (C->S|S->C) (\d+)->(\d+) len=(\d+) (b'.*')$")


def _datagrams(name: str) -> list[tuple[str, int, int, bytes]]:
    out = []
    for line in (CAPTURES / name).read_text().splitlines():
        m = LINE.match(line)
        if m:
            data = ast.literal_eval(m.group(6))
            assert len(data) == int(m.group(5))
            out.append((m.group(2), int(m.group(3)), int(m.group(4)), data))
    return out


CAPTURE_FILES = ["pclient_C1.txt", "robsample_viewer_C1.txt", "gps_beacon_compass_C1.txt", "nbots_refused_C1.txt"]


@pytest.mark.parametrize("name", CAPTURE_FILES)
def test_every_captured_client_datagram_parses(name: str) -> None:
    seen = set()
    for direction, _src, dst, data in _datagrams(name):
        if direction != "C->S":
            continue
        text = data.split(b"\x00")[0]
        if dst == 6000:
            seen.add(parse_registration(data).kind)
        elif re.match(rb"\s*<(Actions|SensorRequests|Say)", text):
            parse_actions(data)
            seen.add("actions")
        else:
            seen.add(parse_viewer_command(data).kind)
    assert seen


def test_registrations_of_the_stock_clients() -> None:
    py = parse_registration(
        b'<Robot Id="1" Name="pyRob"><IRSensor Id="0" Angle="0.0" /><IRSensor Id="1" Angle="60.0" /><IRSensor Id="2" Angle="-60.0" /><IRSensor Id="3" Angle="180.0" /></Robot>'
    )
    assert (py.kind, py.name, py.robot_id, len(py.ir)) == ("robot", "pyRob", 1, 4)
    c = parse_registration(b'<Robot Name="cRob" Id="1"></Robot>\x00')
    assert (c.kind, c.name, c.ir) == ("robot", "cRob", ())
    assert parse_registration(b"<View/>\n\x00").kind == "view"
    beacon = parse_registration(b'<RobotBeacon Name="B" Id="2" Height="4"/>\x00')
    assert (beacon.kind, beacon.beacon_height) == ("beacon", 4.0)
    assert parse_registration(b'<Robot Name="x" Id="abc"/>').robot_id == 0  # a bad Id means "any"


def test_a_plain_ciberrato_robot_is_a_disc_with_four_rim_sensors() -> None:
    spec = registration_spec(parse_registration(b'<Robot Id="1" Name="pyRob"><IRSensor Id="1" Angle="45" /></Robot>'))
    assert spec.shape == BodyShape.CIRCLE
    assert [s.angle_deg for s in spec.sensors] == [0.0, 45.0, -60.0, 180.0]
    assert spec.sensors[1].x_m == pytest.approx(0.5 * 2**-0.5)


def test_intellwheels_registration_with_the_seeds_own_spellings() -> None:
    xml = b'<Robot Name="IntellWheels" Id="1" Width="1.0" Heigth="0.7" COMass="0.6" Type="Real" X="13.0" Y="7.0" DIR="10" MaxSpeed="0.6" AccerelationCurve="0.7"><IRSensor Id="0" X="1.0" Y="0.0" Angle="0.0" Cone="60"/></Robot>'
    spec = registration_spec(parse_registration(xml))
    assert (spec.height_m, spec.com, spec.type, spec.acceleration_curve) == (0.7, 0.6, RobotType.REAL, 0.7)
    assert (spec.x_m, spec.y_m, spec.dir_deg, spec.max_speed_mps) == (13.0, 7.0, 10.0, 0.6)
    assert spec.sensors[0].cone_deg == 60.0


def test_an_intellwheels_field_out_of_range_is_refused_with_its_name() -> None:
    with pytest.raises(SpecError) as e:
        registration_spec(parse_registration(b'<Robot Name="x" COM="1.5"/>'))
    assert e.value.field == "com"


@pytest.mark.parametrize(
    ("data", "why"),
    [
        (b"<Robot Name='a'><Door/></Robot>", "unknown element"),
        (b"<Hello/>", "unknown registration"),
        (b"<Robot", "not well-formed"),
        (b"", "empty"),
        (b"<View/>" + b" " * 1100, "over the 1023-byte limit"),
        (b'<!DOCTYPE r [<!ENTITY a "b">]><Robot Name="&a;"/>', "DOCTYPE"),
    ],
)
def test_bad_registrations_are_refused_with_a_reason(data: bytes, why: str) -> None:
    with pytest.raises(ProtocolError, match=why):
        parse_registration(data)


def test_actions_motors_leds_requests_say_and_pose() -> None:
    a = parse_actions(b'<Actions LeftMotor="0.1" RightMotor="-0.05" VisitingLed="On" EndLed="on"/>')
    assert (a.left, a.right, a.leds) == (0.1, -0.05, {"EndLed": False, "VisitingLed": True})
    assert parse_actions(b'<Actions LeftMotor="abc"/>').left == 0.0  # does not parse: 0, as legacy
    assert parse_actions(b'<Actions RightMotor="0.1"/>').left is None  # missing: sticky
    r = parse_actions(b'<Actions>\n\t<SensorRequests IRSensor0="Yes" Beacon0="Yes" Compass="No"/>\n</Actions>\x00')
    assert r.requests == ("IRSensor0", "Beacon0")
    assert parse_actions(b"<Actions><Say><![CDATA[Hello World!]]></Say></Actions>\n\x00").say == "Hello World!"
    assert parse_actions(b"<Actions> <Say>hi</Say> </Actions>").say == "hi "  # the legacy trailing-space quirk
    assert parse_actions(b"<Actions><Say>" + b"x" * 101 + b"</Say></Actions>").say is None
    assert parse_actions(b'<Actions X="1.5" Y="2" DIR="90"/>').pose == (1.5, 2.0, 90.0)
    with pytest.raises(ProtocolError, match="unknown element <Jump>"):
        parse_actions(b"<Actions><Jump/></Actions>")


def test_viewer_commands() -> None:
    assert parse_viewer_command(b"<LabReq/>\x00").kind == "labreq"
    assert parse_viewer_command(b'<Robot Id="3" Removed="Yes"/>\x00').robot_id == 3
    with pytest.raises(ProtocolError):
        parse_viewer_command(b'<Robot Id="3"/>')
    with pytest.raises(ProtocolError, match="limit"):
        parse_viewer_command(b"<Start/>" + b" " * 80)


def _attrs(data: bytes) -> dict[str, dict[str, str]]:
    root = etree.fromstring(data.split(b"\x00")[0])
    return {el.tag: dict(el.attrib) for el in root.iter()}


def test_the_reply_says_what_the_legacy_server_said_for_c1() -> None:
    captured = next(
        d for direction, _, _, d in _datagrams("pclient_C1.txt") if direction == "S->C" and d.startswith(b"<Reply")
    )
    params = load_parameters(MAPS / "ciberrato" / "C1-config.xml")
    ours = build_reply(params, n_beacons=3, lab_file="Labs/rmi-2122/C1-lab.xml", grid_file="Labs/rmi-2122/C1-grid.xml")
    assert _attrs(ours) == _attrs(captured)
    assert ours.endswith(b"\n\x00")
    assert len(ours) <= 1024


def test_refusal_and_robot_state_are_byte_for_byte_the_legacy_ones() -> None:
    assert build_refusal() == b'<Reply Status="Refused"></Reply>\n\x00'
    captured = next(
        d
        for direction, _, _, d in _datagrams("robsample_viewer_C1.txt")
        if direction == "S->C" and d.startswith(b"<Robot")
    )
    ours = build_robot_state(name="cRob", robot_id=1, time=0, x=3.0, y=11.0, dir_deg=0.0, state="Stopped")
    assert ours == captured


def test_measures_carry_what_the_legacy_server_sends() -> None:
    captured = next(
        d
        for direction, _, _, d in _datagrams("gps_beacon_compass_C1.txt")
        if direction == "S->C" and d.startswith(b"<Measures")
    )
    ours = build_measures(
        Measures(
            time=0,
            collision=False,
            compass=0,
            ground=0,
            ir=(0.7, 2.1, 2.3, 0.6),
            beacons=(-94, None, None),
            gps=(843.2, 405.4),
            buttons=(False, True),
        )
    )
    assert ours == captured  # byte for byte, the space in <GPS ... /> included
    with_msg = build_measures(Measures(time=5, messages=((2, "hello ]]> there"),)))
    assert b'<Message From="2"><![CDATA[hello ]] > there]]></Message>' in with_msg


def test_measures_with_every_optional_part_as_the_fact_sheet_prints_them() -> None:
    ours = build_measures(
        Measures(
            time=123,
            collision=False,
            compass=-90,
            ground=-1,
            ir=(0.6, 0.5, 1.2, 0.3),
            beacons=(45, None),
            gps=(843.2, 401.4),
            messages=((2, "hello"),),
            score=Score(400, arrival_time=5, visited_mask="000"),
            buttons=(True, False),
        )
    )
    assert ours == (
        b'<Measures Time="123">\n'
        b'\t<Sensors Collision="No" Compass="-90" Ground="-1">\n'
        b'\t\t<IRSensor Id="0" Value="0.6"/>\n'
        b'\t\t<IRSensor Id="1" Value="0.5"/>\n'
        b'\t\t<IRSensor Id="2" Value="1.2"/>\n'
        b'\t\t<IRSensor Id="3" Value="0.3"/>\n'
        b'\t\t<BeaconSensor Id="0" Value="45"/>\n'
        b'\t\t<BeaconSensor Id="1" Value="NotVisible"/>\n'
        b'\t\t<GPS X="843.2" Y="401.4" />\n'
        b'\t\t<Message From="2"><![CDATA[hello]]></Message>\n'
        b'\t\t<Score Score="400" ArrivalTime="5" ReturningTime="0" Collisions="0" Collision="False" '
        b'VisitedMask="000" />\n'
        b"\t</Sensors>\n"
        b'\t<Leds EndLed="Off" ReturningLed="Off" VisitingLed="Off"/>\n'
        b'\t<Buttons Start="On" Stop="Off"/>\n'
        b"</Measures>\n\x00"
    )


@given(st.binary(max_size=300))
def test_fuzzed_datagrams_never_crash_the_codec(data: bytes) -> None:
    for parse in (parse_registration, parse_actions, parse_viewer_command):
        with contextlib.suppress(ProtocolError):  # refusing is fine; anything else fails the test
            parse(data)


@given(st.text(max_size=200))
def test_fuzzed_xml_text_never_crashes_the_codec(text: str) -> None:
    data = f'<Actions LeftMotor="{text}"><Say>{text}</Say></Actions>'.encode()
    with contextlib.suppress(ProtocolError):
        parse_actions(data)


def test_heard_text_goes_out_in_latin_1_with_a_question_mark_for_what_latin_1_cannot_hold() -> None:
    text = "x" * 98 + "é€"  # 100 characters, 103 bytes of UTF-8
    assert parse_actions(f"<Actions><Say><![CDATA[{text}]]></Say></Actions>".encode()).say == text
    ours = build_measures(Measures(time=1, messages=((2, text),)))
    assert b"<![CDATA[" + b"x" * 98 + b"\xe9?]]>" in ours  # e-acute is the one byte E9, the euro '?'
    assert "é".encode() not in ours


@given(st.text(st.characters(blacklist_categories=("Cc", "Cs")), max_size=100))
def test_any_heard_text_makes_measures_that_parse_back_as_latin_1(text: str) -> None:
    data = build_measures(Measures(time=1, messages=((2, text),)))
    assert data.endswith(b"\n\x00")
    root = etree.fromstring(data[:-1], etree.XMLParser(encoding="iso-8859-1"))
    kept = text.encode("latin-1", "replace").decode("latin-1").replace("]]>", "]] >")
    assert (root.find("Sensors/Message").text or "") == kept
