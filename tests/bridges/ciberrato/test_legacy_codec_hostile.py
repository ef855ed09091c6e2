"""Hostile input to the legacy codec's parsers: every refusal is a ProtocolError with a reason,
and nothing else ever escapes (a numeric field in non-ASCII digits included)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from iw_zenoh.bridges.ciberrato.codec import parse_actions, parse_viewer_command
from iw_zenoh.bridges.ciberrato.registration import parse_registration
from lxml import etree

from iw_zenoh.errors import ProtocolError

PARSERS = (parse_registration, parse_actions, parse_viewer_command)
# what XML attributes can hold, with the digits of many scripts (², ٣, ①: str.isdigit() holds)
TEXT = st.text(st.characters(blacklist_categories=("Cs", "Cc")), max_size=12) | st.sampled_from(
    ["²", "٣", "①", "𝟙", "1²", " 7 ", "007", "-1", "1e3", ""]
)


def _outcome(parse: object, data: bytes) -> str:
    """ "ok", or the refusal's reason; anything but a ProtocolError fails the test."""
    assert callable(parse)
    reason = "ok"
    try:
        parse(data)
    except ProtocolError as e:
        reason = str(e)
    assert reason, f"{parse.__name__} refused {data!r} without a reason"
    return reason


@given(st.binary(max_size=200))
def test_arbitrary_bytes_are_parsed_or_refused_with_a_reason(data: bytes) -> None:
    for parse in PARSERS:
        _outcome(parse, data)


@given(TEXT, TEXT, TEXT)
def test_arbitrary_numeric_fields_are_parsed_or_refused_with_a_reason(
    robot_id: str, sensor_id: str, angle: str
) -> None:
    reg = etree.Element("Robot", Id=robot_id, Name="bot")
    etree.SubElement(reg, "IRSensor", Id=sensor_id, Angle=angle)
    beacon = etree.Element("RobotBeacon", Id=robot_id, Name="b", Height=angle)
    removed = etree.Element("Robot", Id=robot_id, Removed="Yes")
    for root in (reg, beacon):
        _outcome(parse_registration, etree.tostring(root, encoding="utf-8"))
    _outcome(parse_viewer_command, etree.tostring(removed, encoding="utf-8"))


@pytest.mark.parametrize("digits", ["²", "٣", "①", "1²"])
def test_an_id_in_non_ascii_digits_is_refused_with_its_reason(digits: str) -> None:
    for data, parse in (
        (f'<Robot Id="{digits}" Name="bot"/>', parse_registration),
        (f'<Robot Id="1" Name="bot"><IRSensor Id="{digits}" Angle="0"/></Robot>', parse_registration),
        (f'<Robot Id="{digits}" Removed="Yes"/>', parse_viewer_command),
    ):
        with pytest.raises(ProtocolError, match="ASCII digits"):
            parse(data.encode())


def test_ids_in_ascii_digits_and_the_legacy_any_id_still_parse() -> None:
    assert parse_registration(b'<Robot Id=" 12 " Name="bot"/>').robot_id == 12
    assert parse_registration(b'<Robot Id="any" Name="bot"/>').robot_id == 0
    assert parse_viewer_command(b'<Robot Id="4" Removed="Yes"/>').robot_id == 4
