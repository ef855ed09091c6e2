from __future__ import annotations

from pathlib import Path

import pytest

from iw_zenoh.config import parse_scenario
from iw_zenoh.errors import ConfigError
from iw_zenoh.nodes.child import Child
from iw_zenoh.nodes.secure_run import agent_robots, on_host

MAPS = Path(__file__).resolve().parents[2] / "maps"
AGENTS = """
[world]
map = "liacc.xml"
[[agents]]
program = "waypoint"
args = ["--id", "2"]
[[agents]]
program = "wanderer"
robots = 2
name = "crowd"
[[agents]]
program = "waypoint"
args = ["--id", "1"]
"""


def test_an_agents_robots_are_its_id_or_the_lowest_ids_no_other_asks_for() -> None:
    sc = parse_scenario(AGENTS, MAPS)
    assert agent_robots(sc) == {"agent-1-waypoint": (2,), "crowd": (3, 4), "agent-3-waypoint": (1,)}


def _children(*names: str) -> list[Child]:
    return [Child(n.split("-")[0], n, [], Path(f"{n}.log")) for n in names]


def test_a_host_runs_what_the_scenario_gives_it_and_the_routers_host_the_rest() -> None:
    children = _children("router", "world", "collision", "sensors-1", "alice")
    hosts = {"b": ["collision", "alice"]}
    assert [c.name for c in on_host(children, hosts, "b")] == ["collision", "alice"]
    assert [c.name for c in on_host(children, hosts, "")] == ["router", "world", "sensors-1"]


@pytest.mark.parametrize(("hosts", "host", "field"), [({"b": ["nobody"]}, "", "security.hosts.b"), ({}, "c", "--host")])
def test_an_unknown_host_or_process_is_refused_naming_it(hosts: dict[str, list[str]], host: str, field: str) -> None:
    with pytest.raises(ConfigError) as e:
        on_host(_children("router", "world"), hosts, host)
    assert e.value.field == field
