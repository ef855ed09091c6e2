"""Driving from the page, the viewer's part: a page's ``drive`` command checked at the edge and
relayed to the chair's drive key as a valid ``DriveInput`` under the page's driver name; the
chairs' drive states told to the pages; a secured viewer drives only the chairs its policy grants."""

from __future__ import annotations

import threading
from pathlib import Path

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from iw_zenoh import keys
from iw_zenoh.bus import Inbox
from iw_zenoh.messages import decode, encode
from iw_zenoh.messages.drive import DRIVER_MAX, DriveInput, DriveState
from iw_zenoh.messages.page import PageCommand, PageDrive, PageDriveInput
from iw_zenoh.viewer.drive import DriveGrant, Drives, decode_state, driver_name
from iw_zenoh.viewer.feed import Feed
from iw_zenoh.viewer.guard import check_command
from iw_zenoh.viewer.sources import LiveSource, LocalBus

_DECODE = msgspec.json.Decoder(PageCommand)


def _live(grant: DriveGrant | None = None) -> tuple[LiveSource, Inbox]:
    out = Inbox()
    return LiveSource(LocalBus(out), "s", threading.Event(), grant), out


def test_a_pages_drive_becomes_the_chairs_drive_input_under_its_driver_name() -> None:
    source, out = _live()
    d = PageDriveInput(seq=7, x=-0.5, y=1.0, buttons=1, level=3, take=True, goto=(2.5, 4.0), assist="safe")
    assert source.drive(4, "view#2", d) == ""
    [(key, data, *_)] = out.drain()
    assert key == keys.drive("s", 4)
    got = decode(data, DriveInput)
    assert got == DriveInput(
        robot_id=4, driver="view#2", seq=7, x=-0.5, y=1.0, buttons=1, level=3, take=True, goto=(2.5, 4.0), assist="safe"
    )


def test_driver_names_fit_the_protocol_and_differ_per_page() -> None:
    assert driver_name("view", 3) == "view#3"
    long = driver_name("v" * 200, 123456)
    assert len(long) == DRIVER_MAX
    assert long.endswith("#123456")


def test_a_watch_page_may_not_drive_and_a_drive_needs_its_input_and_a_finite_goal() -> None:
    ok = PageCommand(cmd="drive", robot_id=1, drive=PageDriveInput(y=1.0, buttons=1))
    assert check_command(ok, "steer") == ""
    assert "watch" in check_command(ok, "watch")
    assert "input" in check_command(PageCommand(cmd="drive", robot_id=1), "steer")
    far = PageCommand(cmd="drive", robot_id=1, drive=PageDriveInput(goto=(1e9, 0.0)))
    assert "finite" in check_command(far, "steer")


HOSTILE: list[object] = [None, True, -2, 2, 1e308, float("inf"), "1", [], {}, 2**63, -1]
DRIVE_FIELDS = ["seq", "x", "y", "buttons", "level", "take", "release", "goto", "assist", "extra"]


def _through(raw: bytes) -> str:
    """A page's message as the server takes it: refused (why), or relayed as a valid DriveInput."""
    try:
        cmd = _DECODE.decode(raw)
    except msgspec.DecodeError as e:
        return str(e) or "refused"
    if why := check_command(cmd, "steer"):
        return why
    source, out = _live()
    assert cmd.drive is not None
    source.drive(cmd.robot_id, "view#1", cmd.drive)  # must not raise
    for _, data, *_ in out.drain():
        decode(data, DriveInput)  # what went to the chair is valid
    return ""


def test_every_hostile_value_in_every_field_of_a_drive_is_refused_or_harmless() -> None:
    for f in DRIVE_FIELDS:
        for v in HOSTILE:
            _through(msgspec.json.encode({"cmd": "drive", "robot_id": 1, "drive": {f: v}}))
    for bad in ({"x": 1.5}, {"y": -1.01}, {"level": 0}, {"level": 6}, {"assist": "turbo"}, {"goto": [1, 2, 3]}):
        assert _through(msgspec.json.encode({"cmd": "drive", "robot_id": 1, "drive": bad})), bad
    assert _through(b'{"cmd":"drive","robot_id":1,"drive":{"x":NaN}}')
    assert _through(b'{"cmd":"drive","robot_id":1,"drive":{"goto":[1e400,0]}}')


JSON = st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8) | st.lists(st.floats(), max_size=3)


@settings(max_examples=300, deadline=None)
@given(fields=st.dictionaries(st.sampled_from(DRIVE_FIELDS), JSON, max_size=5), rid=st.integers() | st.text(max_size=3))
def test_fuzzed_drive_commands_never_raise_past_the_edge(fields: dict[str, object], rid: object) -> None:
    _through(msgspec.json.encode({"cmd": "drive", "robot_id": rid, "drive": fields}))


def _state(rid: int, **over: object) -> DriveState:
    return msgspec.structs.replace(DriveState(robot_id=rid, driver="view#1", level=2), **over)


def test_the_pages_are_told_each_change_of_a_chairs_drive_state_and_a_joining_page_all() -> None:
    drives = Drives()
    a = _state(3)
    assert drives.on_state(3, a) == [PageDrive(robot_id=3, state=a)]
    assert drives.on_state(3, a) == []  # unchanged: not sent again
    b = _state(3, driver="view#2")
    assert drives.on_state(3, b) == [PageDrive(robot_id=3, state=b)]
    assert drives.snapshot() == [PageDrive(robot_id=3, state=b)]
    assert drives.keep([1, 2]) == [PageDrive(robot_id=3, state=None)]  # the chair left
    assert drives.snapshot() == []


def test_a_drive_state_on_another_chairs_key_or_malformed_is_dropped() -> None:
    assert decode_state(keys.driving("s", 3), encode(_state(3))) == (3, _state(3))
    assert decode_state(keys.driving("s", 4), encode(_state(3))) is None
    assert decode_state(keys.driving("s", 3), b'{"robot_id": 3, "v_mps": "fast"}') is None


def test_a_live_source_tells_a_joining_page_every_chairs_drive_state() -> None:
    source, _ = _live()
    source.inbox.put((keys.driving("s", 5), encode(_state(5)), 0))  # as the bus delivers it
    out = source.poll(Feed("s"), 0)
    assert out == [PageDrive(robot_id=5, state=_state(5))]
    assert source.extra() == [PageDrive(robot_id=5, state=_state(5))]


def _policy(tmp: Path, text: str) -> str:
    (tmp / "policy.toml").write_text(f'sim = "s"\n{text}')
    return str(tmp / "watcher")


def test_a_secured_viewer_drives_only_the_chairs_its_policy_grants(tmp_path: Path) -> None:
    grant = DriveGrant(_policy(tmp_path, '[identities.watcher]\nrole = "viewer"\nrobots = [2]\n'))
    source, out = _live(grant)
    assert source.drive(2, "watcher#1", PageDriveInput(y=1.0, buttons=1)) == ""
    why = source.drive(3, "watcher#1", PageDriveInput(y=1.0, buttons=1))
    assert "may not drive chair 3" in why
    assert "[2]" in why
    assert "robots = [3]" in why
    assert [k for k, *_ in out.drain()] == [keys.drive("s", 2)]  # nothing went to chair 3


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ('[identities.other]\nrole = "viewer"\n', "does not name"),
        ("this is not toml [", "cannot read the policy"),
    ],
)
def test_a_secured_viewer_whose_policy_does_not_grant_it_drives_nothing_and_says_why(
    tmp_path: Path, text: str, said: str
) -> None:
    source, out = _live(DriveGrant(_policy(tmp_path, text)))
    assert said in source.drive(1, "watcher#1", PageDriveInput())
    assert out.drain() == []


def test_an_unsecured_viewer_drives_any_chair_and_a_replay_none() -> None:
    assert DriveGrant(None).refusal(12345) == ""
