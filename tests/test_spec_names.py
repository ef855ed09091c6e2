"""One vocabulary for a chair's spec (issue #31): its fields carry the same names, units and all,
in Python (``RobotSpec``), in spec files and scenarios, and on the wire (``RobotSpecMsg``); a name
from before is refused in a user's file with the new one, its file and line; the messages written
before (recordings) still decode."""

from __future__ import annotations

import contextlib
import dataclasses
import json
from pathlib import Path

import msgspec
import pytest
from hypothesis import given
from hypothesis import strategies as st

from iw_zenoh.convert import spec_from_msg
from iw_zenoh.core.spec import IrSensorSpec, LaserSpec, RobotSpec
from iw_zenoh.errors import ConfigError, DecodeError
from iw_zenoh.messages import (
    IrSensorMsg,
    LabMsg,
    LaserMsg,
    RegisterReply,
    RegisterRequest,
    RobotSpecMsg,
    WorldInfo,
    decode,
)
from iw_zenoh.scenario.file import parse_scenario
from iw_zenoh.scenario.specfile import apply_spec, load_spec_file

ROOT = Path(__file__).resolve().parents[1]
OLD = {"width": 1.2, "height": 0.7, "x": 2.0, "y": 3.0, "dir": 45.0, "max_speed": 0.8, "beacon_height": 0.5}
OLD_SENSOR = {"id": 0, "x": 0.4, "y": -0.1}


def test_the_spec_has_one_set_of_names_in_python_and_on_the_wire() -> None:
    python = {f.name for f in dataclasses.fields(RobotSpec)} - {"encoder"}  # encoder.ticks_per_m: flat on the wire
    assert python | {"ticks_per_m"} == set(RobotSpecMsg.__struct_fields__)
    assert {f.name for f in dataclasses.fields(IrSensorSpec)} == set(IrSensorMsg.__struct_fields__)
    assert {f.name for f in dataclasses.fields(LaserSpec)} == set(LaserMsg.__struct_fields__)


def test_a_spec_file_under_the_old_names_is_refused_with_the_new_one_its_file_and_line(tmp_path: Path) -> None:
    f = tmp_path / "chair.toml"
    f.write_text("# my chair\n[chair]\ncom = 0.8\nwidth = 1.2\n")
    with pytest.raises(ConfigError) as e:
        load_spec_file(f)
    assert e.value.field == f"{f}, line 4: chair.width"
    assert "'width' is now 'width_m'" in e.value.reason
    f.write_text("[chair]\nir_sensors = [\n  { id = 0, x = 0.4 },\n]\n")
    with pytest.raises(ConfigError) as e:
        load_spec_file(f)
    assert e.value.field == f"{f}, line 3: chair.ir_sensors[0].x"
    assert "'x' is now 'x_m'" in e.value.reason
    f.write_text("[chair]\nwidth_m = 1.2\nmax_speed_mps = 0.8\nir_sensors = [{ id = 0, x_m = 0.4 }]\n")
    spec = apply_spec(RobotSpec("c"), load_spec_file(f))
    assert (spec.width_m, spec.max_speed_mps, spec.ir_sensors[0].x_m) == (1.2, 0.8, 0.4)


@pytest.mark.parametrize(("old", "new"), [(k, k + {"dir": "_deg", "max_speed": "_mps"}.get(k, "_m")) for k in OLD])
def test_a_scenario_table_under_an_old_name_is_refused_at_its_line(tmp_path: Path, old: str, new: str) -> None:
    (tmp_path / "m.xml").write_text('<Lab Name="m" Width="10" Height="5"></Lab>')
    text = f'[world]\nmap = "m.xml"\n\n[[agents]]\nprogram = "waypoint"\nspec = {{ {old} = 2.0 }}\n'
    with pytest.raises(ConfigError) as e:
        parse_scenario(text, tmp_path)
    assert e.value.field == f"line 6: agents[0].spec.{old}"
    assert f"{old!r} is now {new!r}" in e.value.reason
    assert apply_spec(RobotSpec("c"), {new: 2.0}) != RobotSpec("c")  # the new name is taken


def _old_spec(name: str = "old") -> dict[str, object]:
    return {"name": name, "id": 1, **OLD, "ir_sensors": [OLD_SENSOR], "lasers": [{**OLD_SENSOR, "beams": 3}]}


def test_messages_written_before_the_rename_still_decode_as_the_new_names() -> None:
    want = RobotSpecMsg(
        name="old",
        id=1,
        width_m=1.2,
        height_m=0.7,
        x_m=2.0,
        y_m=3.0,
        dir_deg=45.0,
        max_speed_mps=0.8,
        beacon_height_m=0.5,
        ir_sensors=[IrSensorMsg(id=0, x_m=0.4, y_m=-0.1)],
        lasers=[LaserMsg(id=0, x_m=0.4, y_m=-0.1, beams=3)],
    )
    stamp = {"tick": 3, "sim_time_ns": 300}
    req = decode(json.dumps({**stamp, "spec": _old_spec(), "agent": "a"}).encode(), RegisterRequest)
    assert req.spec == want
    reply = decode(json.dumps({**stamp, "ok": True, "robot_id": 1, "spec": _old_spec()}).encode(), RegisterReply)
    assert reply.spec == want
    lab = msgspec.to_builtins(LabMsg(name="l", width=5, height=5))
    info = {**stamp, "revision": 1, "lab": lab, "period_ns": 1, "robots": [_old_spec(), _old_spec("b") | {"id": 2}]}
    robots = decode(json.dumps(info).encode(), WorldInfo).robots
    assert robots[0] == want
    assert spec_from_msg(robots[1]).max_speed_mps == 0.8
    # an old name beside its new one, an unknown field, a wrong type: refused as before
    for spec in ({"name": "a", "width": 1.0, "width_m": 1.0}, {"name": "a", "wheels": 3}, {"name": "a", "x": "far"}):
        with pytest.raises(DecodeError):
            decode(json.dumps({**stamp, "agent": "a", "spec": spec}).encode(), RegisterRequest)


@given(
    st.recursive(
        st.none() | st.booleans() | st.floats() | st.text(max_size=5),
        lambda c: (
            st.lists(c, max_size=3)
            | st.dictionaries(
                st.sampled_from([*OLD, "name", "ir_sensors", "lasers", "robots", "spec", "id"]), c, max_size=4
            )
        ),
        max_leaves=20,
    )
)
def test_any_json_is_decoded_or_refused_with_a_decode_error(doc: object) -> None:
    data = json.dumps({"tick": 1, "sim_time_ns": 1, "spec": doc, "robots": doc, "ok": True}).encode()
    for kind in (RegisterRequest, RegisterReply):
        with contextlib.suppress(DecodeError):
            decode(data, kind)


def _chair_scenario(tmp_path: Path, start: str) -> str:
    (tmp_path / "m.xml").write_text('<Lab Name="m" Width="20" Height="10"></Lab>')
    return f'[world]\nmap = "m.xml"\n[chair]\nstart = {start}\n'


def test_a_chairs_start_is_a_typed_table_and_the_old_string_is_refused_with_the_table_to_write(tmp_path: Path) -> None:
    from iw_zenoh.launch.launcher import Launcher
    from iw_zenoh.scenario.tables import Start

    sc = parse_scenario(_chair_scenario(tmp_path, "{ x_m = 1.5, y_m = 3, dir_deg = -90 }"), tmp_path)
    assert sc.chair is not None
    assert sc.chair.start == Start(x_m=1.5, y_m=3.0, dir_deg=-90.0)
    launcher = Launcher(sc, port=7447, log_dir=tmp_path, status=False)
    launcher.plan()
    starts = [c.argv[c.argv.index("--start") + 1] for c in launcher.children if "--start" in c.argv]
    assert starts == ["1.5,3.0,-90.0", "1.5,3.0,-90.0"]  # the emulator and the bridge, as they read it
    with pytest.raises(ConfigError) as e:
        parse_scenario(_chair_scenario(tmp_path, '"1.5,3,0"'), tmp_path)
    assert e.value.field == "chair.start"
    assert "write start = { x_m = 1.5, y_m = 3, dir_deg = 0 }" in e.value.reason
    with pytest.raises(ConfigError) as e:
        parse_scenario(_chair_scenario(tmp_path, "{ x_m = 1, y_m = 1, dir_deg = 270 }"), tmp_path)
    assert e.value.field == "chair.start.dir_deg"


def test_goals_are_recorded_as_typed_json_and_the_old_text_is_still_read(tmp_path: Path) -> None:
    from iw_zenoh.launch.launcher import Launcher
    from iw_zenoh.record.metrics import Goal, recorded_goals

    (tmp_path / "m.xml").write_text('<Lab Name="m" Width="20" Height="10"></Lab>')
    text = '[world]\nmap = "m.xml"\n[[criteria.reach]]\nrobot = 1\nx_m = 10.5\ny_m = 3\n[[criteria.reach]]\nrobot = 2\nx_m = 4\ny_m = 5\nwithin_m = 0.25\n'
    launcher = Launcher(
        parse_scenario(text, tmp_path), port=7447, log_dir=tmp_path, status=False, record=tmp_path / "r.mcap"
    )
    launcher.plan()
    meta = next(c.options for c in launcher.children if c.role == "record").meta  # type: ignore[union-attr]
    assert json.loads(meta["goals"]) == [
        {"robot": 1, "x_m": 10.5, "y_m": 3.0, "within_m": 0.5},
        {"robot": 2, "x_m": 4.0, "y_m": 5.0, "within_m": 0.25},
    ]
    want = {1: Goal(10.5, 3.0, 0.5), 2: Goal(4.0, 5.0, 0.25)}
    assert recorded_goals(meta["goals"]) == want
    assert recorded_goals("1=10.5,3.0,0.5;2=4.0,5.0,0.25") == want  # a recording made before
    for bad in (
        '[{"robot": 1}]',
        '[{"robot": 1, "x_m": 1, "y_m": 2, "within_m": 0}]',
        "[",
        '[{"robot": 1, "x_m": NaN}]',
    ):
        with pytest.raises(ValueError, match="goals"):
            recorded_goals(bad)
