from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from iw_zenoh.errors import ConfigError
from iw_zenoh.scenario.file import load_scenario, parse_scenario

MAPS = Path(__file__).resolve().parents[2] / "maps"


def test_the_demo_scenario_loads() -> None:
    sc = load_scenario(MAPS / "scenarios" / "demo.toml")
    assert sc.robots == 3
    assert sc.criteria.max_collisions == 0
    assert [o.name for o in sc.obstacles] == ["A", "B"]


@pytest.mark.parametrize(
    ("toml", "field"),
    [
        ("", "scenario.world"),
        ('[world]\nmap = "nope.xml"', "world.map"),
        ('[world]\nmap = "liacc.xml"\nmode = "fast"', "world.mode"),
        ('[world]\nmap = "liacc.xml"\nperiod_ms = -5', "world.period_ms"),
        ('[world]\nmap = "liacc.xml"\nspeed = 3', "world.speed"),
        ('[world]\nmap = "liacc.xml"\n[[agents]]\nargs = []', "agents[0].program"),
        ('[world]\nmap = "liacc.xml"\n[[obstacles]]\nname = "A"\nx0 = "a"', "obstacles[0].x0"),
        ('[world]\nmap = "liacc.xml"\n[criteria]\nmax_collisions = -1', "criteria.max_collisions"),
        ('[world]\nmap = "liacc.xml"\n[[criteria.reach]]\nx_m = 1\ny_m = 2', "criteria.reach[0].robot"),
        ("[world\n", "scenario"),
    ],
)
def test_bad_scenarios_are_refused_naming_the_field(toml: str, field: str) -> None:
    with pytest.raises(ConfigError) as e:
        parse_scenario(toml, MAPS)
    assert e.value.field == field


def test_a_scenario_file_that_is_not_text_is_refused_naming_it(tmp_path: Path) -> None:
    bad = tmp_path / "binary.toml"
    bad.write_bytes(b"\xff\xfe\x00\x01 not toml")
    with pytest.raises(ConfigError) as e:
        load_scenario(bad)
    assert str(bad) in e.value.field
    assert "UTF-8" in e.value.reason


def test_a_refusal_names_the_field_path_and_the_value() -> None:
    with pytest.raises(ConfigError) as e:
        parse_scenario('[world]\nmap = "liacc.xml"\n[[agents]]\nprogram = "waypoint"\nrobots = -1', MAPS)
    assert e.value.field == "agents[0].robots"
    assert "-1" in e.value.reason


def test_scenario_paths_are_relative_to_the_file() -> None:
    sc = load_scenario(MAPS / "scenarios" / "ciberrato-c1.toml")
    assert sc.world.map == MAPS / "ciberrato" / "C1-lab.xml"
    assert sc.bridge is not None
    assert sc.bridge.params is None or sc.bridge.params.is_file()


def test_a_serial_chair_scenario_names_its_bridge_and_emulator() -> None:
    sc = load_scenario(MAPS / "scenarios" / "find-the-box-serial.toml")
    assert sc.chair is not None
    assert (sc.chair.hardware, sc.chair.port, sc.chair.robot) == ("serial", "", 1)
    assert not isinstance(sc.chair.room, str)
    assert [box.arg for box in sc.chair.room] == ["8.2,3.4,8.8,5.0"]  # as the emulator's --room takes it


@pytest.mark.parametrize(
    ("room", "written"),
    [
        ('"8.2,3.4,8.8,5.0"', "room = [{ x0_m = 8.2, y0_m = 3.4, x1_m = 8.8, y1_m = 5.0 }]"),
        (
            '"1,2,3,4;5,6,7,8"',
            "room = [{ x0_m = 1, y0_m = 2, x1_m = 3, y1_m = 4 }, { x0_m = 5, y0_m = 6, x1_m = 7, y1_m = 8 }]",
        ),
        ('""', "room = []"),
    ],
)
def test_a_chair_room_as_a_string_is_refused_at_its_line_with_the_table_to_write(room: str, written: str) -> None:
    text = f'[world]\nmap = "liacc.xml"\n[chair]\nport = "/dev/null"\nroom = {room}\n'
    with pytest.raises(ConfigError) as e:
        parse_scenario(text, MAPS)
    assert e.value.field == "line 5: chair.room"
    assert f"write {written} (docs/scenarios.md)" in e.value.reason


@pytest.mark.parametrize(
    ("toml", "field"),
    [
        ('[world]\nmap = "liacc.xml"\n[chair]\nhardware = "emulated"', "chair.hardware"),
        ('[world]\nmap = "liacc.xml"\nmode = "lockstep"\n[chair]\nhardware = "serial"', "chair.hardware"),
        ('[world]\nmap = "liacc.xml"\n[chair]\nrobot = 0', "chair.robot"),
        ('[world]\nmap = "liacc.xml"\n[chair]\nstart = "1,2"', "chair.start"),
        ('[world]\nmap = "liacc.xml"\n[chair]\nwheels = 4', "chair.wheels"),
    ],
)
def test_bad_chair_tables_are_refused_naming_the_field(toml: str, field: str) -> None:
    with pytest.raises(ConfigError) as e:
        parse_scenario(toml, MAPS)
    assert e.value.field == field


@pytest.mark.parametrize(
    ("toml", "field"),
    [
        ('[world]\nmap = "liacc.xml"\n[[criteria.doors]]\nopened = true', "criteria.doors[0].robot"),
        ('[world]\nmap = "liacc.xml"\n[[criteria.doors]]\nrobot = 1\none_chair_within_m = 1.0', "criteria.doors[0]"),
        ('[world]\nmap = "liacc.xml"\n[[criteria.doors]]\nrobot = 1\nsymmetry_deg = 400', "criteria.doors[0]"),
        ('[world]\nmap = "liacc.xml"\n[[criteria.doors]]\nrobot = 1\nwide = 2', "criteria.doors[0].wide"),
    ],
)
def test_bad_door_criteria_are_refused_naming_the_field(toml: str, field: str) -> None:
    with pytest.raises(ConfigError) as e:
        parse_scenario(toml, MAPS)
    assert e.value.field.startswith(field), e.value


@pytest.mark.parametrize(
    ("args", "written"),
    [
        ('["--lockstep-timeout-ms", "60000"]', "lockstep_timeout_ms = 60000"),
        ('["--motors-noise", 1.5, "--paused"]', "motors_noise_pct = 1.5; start_paused = true"),
        ('["--silence", "keep"]', 'silence = "keep"'),
    ],
)
def test_world_args_are_refused_at_their_line_with_the_fields_to_write(args: str, written: str) -> None:
    text = f'name = "old"\n[world]\nmap = "liacc.xml"\n# a comment\nargs = {args}\n[[agents]]\nprogram = "waypoint"\nargs = []\n'
    with pytest.raises(ConfigError) as e:
        parse_scenario(text, MAPS)
    assert e.value.field == "line 5: world.args"
    assert f"write {written} " in e.value.reason


def test_the_world_options_are_typed_fields_of_world() -> None:
    text = (
        '[world]\nmap = "liacc.xml"\nlockstep_timeout_ms = 60000\ngrace_ms = 1000\nmotors_noise_pct = 1.5\n'
        'silence = "keep"\nstart_paused = true\naction_timeout_ms = 300\nexpect = 2\n'
    )
    w = parse_scenario(text, MAPS).world
    assert (w.lockstep_timeout_ms, w.grace_ms, w.motors_noise_pct, w.silence) == (60000, 1000, 1.5, "keep")
    assert (w.start_paused, w.action_timeout_ms, w.expect) == (True, 300, 2)


@pytest.mark.parametrize(
    ("toml", "field"),
    [
        ('lockstep_timeout_ms = "60000"', "world.lockstep_timeout_ms"),
        ("lockstep_timeout_ms = -1", "world.lockstep_timeout_ms"),
        ('silence = "sometimes"', "world.silence"),
        ("motors_noise_pct = 200", "world.motors_noise_pct"),
        ("expect = -1", "world.expect"),
    ],
)
def test_bad_world_options_are_refused_naming_the_field(toml: str, field: str) -> None:
    with pytest.raises(ConfigError) as e:
        parse_scenario(f'[world]\nmap = "liacc.xml"\n{toml}\n', MAPS)
    assert e.value.field == field
    assert "unknown" not in e.value.reason  # a field of [world], its value refused


@pytest.mark.parametrize(
    ("criterion", "field", "new"),
    [
        ("[[criteria.reach]]\nrobot = 1\nx_m = 1\ny = 2\n", "line 10: criteria.reach[1].y", "'y' is now 'y_m'"),
        (
            "[[criteria.reach]]\nrobot = 1\nx_m = 1\ny_m = 2\nwithin = 0.3\n",
            "line 11: criteria.reach[1].within",
            "'within' is now 'within_m'",
        ),
        ("[[criteria.doors]]\nrobot = 1\nx = 10\n", "line 9: criteria.doors[0].x", "'x' is now 'x_m'"),
        (
            "[[criteria.doors]]\nrobot = 1\none_chair_within = 1.0\n",
            "line 9: criteria.doors[0].one_chair_within",
            "'one_chair_within' is now 'one_chair_within_m'",
        ),
    ],
)
def test_criteria_lengths_under_their_old_names_are_refused_at_their_line_naming_the_new(
    criterion: str, field: str, new: str
) -> None:
    first = "[[criteria.reach]]\nrobot = 2\nx_m = 3\ny_m = 4\n"  # lines 3-6: the new names pass; the old one below is at line 7 + its place
    text = f'[world]\nmap = "liacc.xml"\n{first}{criterion}'
    with pytest.raises(ConfigError) as e:
        parse_scenario(text, MAPS)
    assert (e.value.field, e.value.reason.split(":")[0]) == (field, new)


def test_criteria_lengths_carry_their_units() -> None:
    text = (
        '[world]\nmap = "liacc.xml"\n[[criteria.reach]]\nrobot = 2\nx_m = 3\ny_m = 4\nwithin_m = 0.25\n'
        "[[criteria.doors]]\nrobot = 1\nx_m = 10\ny_m = 5\none_chair_within_m = 1.0\n"
    )
    crit = parse_scenario(text, MAPS).criteria
    assert (crit.reach[0].x_m, crit.reach[0].y_m, crit.reach[0].within_m) == (3, 4, 0.25)
    assert (crit.doors[0].x_m, crit.doors[0].y_m, crit.doors[0].one_chair_within_m) == (10, 5, 1.0)


def test_an_old_name_set_from_the_command_line_is_refused_naming_the_new() -> None:
    text = '[world]\nmap = "liacc.xml"\n[[criteria.reach]]\nrobot = 2\nx_m = 3\ny_m = 4\n'
    with pytest.raises(ConfigError) as e:
        parse_scenario(text, MAPS, sets=[("criteria.reach[0].within", 1.0)])
    assert (e.value.field, e.value.reason.split(":")[0]) == ("criteria.reach[0].within", "'within' is now 'within_m'")


_KEYS = ("robot", "x", "y", "within", "one_chair_within", "x_m", "y_m", "within_m", "one_chair_within_m", "wide")
_VALUES = st.booleans() | st.integers(-5, 5) | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=4)
_TABLES = st.lists(st.dictionaries(st.sampled_from(_KEYS), _VALUES, max_size=5), max_size=3)


def _toml_value(v: object) -> str:
    return json.dumps(v) if not isinstance(v, float) else repr(v)


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(["reach", "doors"]), _TABLES, _TABLES)
def test_any_criteria_table_is_read_or_refused_naming_a_field(
    array: str, written: list[dict[str, object]], set_: list[dict[str, object]]
) -> None:
    text = '[world]\nmap = "liacc.xml"\n' + "".join(
        f"[[criteria.{array}]]\n" + "".join(f"{k} = {_toml_value(v)}\n" for k, v in item.items()) for item in written
    )
    for sets in ([], [(f"criteria.{array}", set_)]):
        refused = None
        try:
            parse_scenario(text, MAPS, sets=sets)
        except ConfigError as e:
            refused = e
        assert refused is None or (refused.field and refused.reason)  # never another exception
