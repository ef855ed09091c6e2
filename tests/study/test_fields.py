"""``--set FIELD=VALUE``: a scenario field by its path, its value as TOML (text otherwise), checked
as the file is; anything else refused with a ConfigError naming the field, never another error."""

from __future__ import annotations

import contextlib
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from iw_zenoh.errors import ConfigError
from iw_zenoh.scenario.fields import apply_sets, parse_set
from iw_zenoh.scenario.file import parse_scenario

TOML = """
name = "s"
[world]
map = "lab.xml"
duration_s = 60
[[agents]]
program = "waypoint"
args = ["--waypoints", "5,5"]
"""


@pytest.fixture
def base(tmp_path: Path) -> Path:
    (tmp_path / "lab.xml").write_text('<Lab Name="hall" Width="20" Height="10"/>')
    return tmp_path


def test_values_are_read_as_toml_and_otherwise_as_text() -> None:
    assert parse_set("world.duration_s=30") == ("world.duration_s", 30)
    assert parse_set("roles.radio=false") == ("roles.radio", False)
    assert parse_set('agents[0].args=["--id", "1"]') == ("agents[0].args", ["--id", "1"])
    assert parse_set("agents[0].spec={ max_speed_mps = 0.4 }") == ("agents[0].spec", {"max_speed_mps": 0.4})
    assert parse_set("world.map=../other.xml") == ("world.map", "../other.xml")


def test_a_scenario_takes_its_fields_changed(base: Path) -> None:
    sets = [parse_set(s) for s in ("world.duration_s=30", "world.seed=9", "agents[0].spec.max_speed_mps=0.4")]
    sc = parse_scenario(TOML, base, "s", sets)
    assert sc.world.duration_s == 30.0
    assert sc.world.seed == 9
    assert sc.agents[0].spec == {"max_speed_mps": 0.4}


@pytest.mark.parametrize(
    ("text", "field", "why"),
    [
        ("world.nosuch=1", "world.nosuch", "unknown field"),
        ("world.duration_s=-1", "world.duration_s", ">"),
        ("world.seed=nan", "world.seed", "finite"),
        ("agents[3].args=[]", "agents[3].args (at 3)", "no item 3"),
        ("world.map.x=1", "world.map.x (at 'x')", "not a table"),
    ],
)
def test_a_field_refused_is_named_with_the_reason(base: Path, text: str, field: str, why: str) -> None:
    with pytest.raises(ConfigError) as e:
        parse_scenario(TOML, base, "s", [parse_set(text)])
    assert field in str(e.value)
    assert why in str(e.value)


@pytest.mark.parametrize("text", ["world.seed", "=3", "world..seed=1", "agents[x].args=1", "a b=1"])
def test_a_set_not_of_the_form_is_refused_saying_the_form(text: str) -> None:
    with pytest.raises(ConfigError, match="FIELD=VALUE|not a field's path"):
        parse_set(text)


@given(st.text(max_size=60))
def test_any_text_is_a_set_or_a_config_error(text: str) -> None:
    try:
        field, value = parse_set(text)
    except ConfigError:
        return
    doc: dict[str, object] = {"world": {"map": "x"}, "agents": [{"program": "p"}]}
    with contextlib.suppress(ConfigError):
        apply_sets(doc, [(field, value)])
