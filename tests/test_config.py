from __future__ import annotations

from pathlib import Path

import pytest

from iw_zenoh.config import load_scenario, parse_scenario
from iw_zenoh.errors import ConfigError

MAPS = Path(__file__).resolve().parents[1] / "maps"


def test_the_demo_scenario_loads() -> None:
    sc = load_scenario(MAPS / "demo.toml")
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
        ('[world]\nmap = "liacc.xml"\n[[criteria.reach]]\nx = 1\ny = 2', "criteria.reach[0].robot"),
        ("[world\n", "scenario"),
    ],
)
def test_bad_scenarios_are_refused_naming_the_field(toml: str, field: str) -> None:
    with pytest.raises(ConfigError) as e:
        parse_scenario(toml, MAPS)
    assert e.value.field == field
