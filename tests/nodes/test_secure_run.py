from __future__ import annotations

from pathlib import Path

import pytest

from iw_zenoh.errors import ConfigError
from iw_zenoh.launch.args import build_parser, scenario_from_args
from iw_zenoh.launch.child import Child
from iw_zenoh.launch.launcher import Launcher
from iw_zenoh.launch.launcher import main as run_main
from iw_zenoh.launch.secure_run import agent_robots, on_host
from iw_zenoh.nodes.world_options import WorldOptions
from iw_zenoh.scenario.file import parse_scenario
from iw_zenoh.secure.policy import load_policy, owners

MAPS = Path(__file__).resolve().parents[2] / "maps"
SCENARIOS = MAPS / "scenarios"
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


def _secured(tmp_path: Path, scenario: str, extra: str = "") -> Launcher:
    sc = parse_scenario((SCENARIOS / scenario).read_text() + extra, SCENARIOS, Path(scenario).stem)
    launcher = Launcher(sc, port=7447, log_dir=tmp_path, status=False, secure=True)
    launcher.plan()
    return launcher


@pytest.mark.parametrize(
    ("scenario", "bridge", "roles"),
    [("ciberrato-c1.toml", "ciberrato", ["bridge", "operator"]), ("slalom-serial.toml", "bridge-serial", ["serial"])],
)
def test_a_secured_runs_bridge_is_an_identity_named_as_it_registers(
    tmp_path: Path, scenario: str, bridge: str, roles: list[str]
) -> None:
    launcher = _secured(tmp_path, scenario)
    policy = load_policy(tmp_path / "ids" / "policy.toml")
    assert list(policy.identities[bridge].roles) == roles  # a legacy viewer's Start needs an operator
    [child] = [c for c in launcher.children if c.role == "bridge"]
    assert child.argv[child.argv.index("--identity") + 1] == str(tmp_path / "ids" / bridge)
    assert (tmp_path / "ids" / f"{bridge}.crt").is_file()
    mine = None if bridge == "ciberrato" else [1]  # a legacy client chooses its id; the chair is robot 1
    assert owners(policy)[bridge] == (None if mine is None else tuple(mine))  # the serial bridge: its chair only
    world = next(c for c in launcher.children if c.role == "world")
    assert isinstance(world.options, WorldOptions)
    assert world.options.owners is not None
    assert world.options.owners[bridge] == mine  # the world registers under the name it asks with
    if bridge == "bridge-serial":
        assert child.argv[child.argv.index("--name") + 1] == bridge  # its own default is serial-PID
        assert policy.identities["agent-1-wheelchair"].robots == [1]  # the chair's agent drives it
        assert "chair" not in policy.identities  # the emulator is on no bus


@pytest.mark.parametrize(("audit", "quiet"), [("", False), ("audit = true", False), ("audit = false", True)])
def test_a_secured_scenario_says_whether_the_router_logs_refusals(tmp_path: Path, audit: str, quiet: bool) -> None:
    launcher = _secured(tmp_path, "ciberrato-c1.toml", f"\n[security]\n{audit}\n")
    router = next(c for c in launcher.children if c.role == "router")
    assert ("--no-audit" in router.argv) == quiet
    assert "--policy" in router.argv  # enforced all the same


@pytest.mark.parametrize(
    ("argv", "quiet"),
    [([], False), (["--no-audit"], True), (["--secure", "--no-audit"], True), (["--secure"], False)],
)
def test_iwz_run_no_audit_starts_a_secured_runs_router_with_no_audit(
    tmp_path: Path, argv: list[str], quiet: bool
) -> None:
    """The scenario's [security] secures the run (but for the last two: --secure does)."""
    text = (MAPS / "scenarios" / "ciberrato-c1.toml").read_text() + ("" if "--secure" in argv else "\n[security]\n")
    args = build_parser().parse_args(["c1.toml", *argv])
    sc = scenario_from_args(parse_scenario(text, SCENARIOS, "c1"), args)
    launcher = Launcher(sc, port=7447, log_dir=tmp_path, status=False, secure=args.secure or sc.security is not None)
    launcher.plan()
    router = next(c for c in launcher.children if c.role == "router")
    assert ("--no-audit" in router.argv) == quiet
    assert "--policy" in router.argv  # enforced all the same


def test_iwz_run_no_audit_in_a_run_not_secured_is_refused_saying_what_to_add(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert run_main([str(MAPS / "scenarios" / "demo.toml"), "--no-audit", "--no-status", "--no-record"]) == 2
    out = capsys.readouterr().out
    assert "iwz run: --no-audit: only a secured run's router logs refusals: add --secure" in out


def test_an_audit_that_is_not_a_bool_is_refused_naming_it() -> None:
    text = (MAPS / "scenarios" / "ciberrato-c1.toml").read_text() + '\n[security]\naudit = "no"\n'
    with pytest.raises(ConfigError) as e:
        parse_scenario(text, SCENARIOS, "c1")
    assert e.value.field == "security.audit"
    assert "Expected `bool`, got `str`" in e.value.reason
