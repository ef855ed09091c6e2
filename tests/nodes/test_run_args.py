"""``iwz run --seed N --set FIELD=VALUE``: the seed and fields a study's run changes, applied before
the scenario is checked; a refused field ends the run before anything starts, naming it."""

from __future__ import annotations

from pathlib import Path

import pytest

from iw_zenoh.launch import launcher
from iw_zenoh.launch.args import build_parser, scenario_sets
from iw_zenoh.scenario.file import load_scenario

TOML = """
name = "s"
[world]
map = "lab.xml"
seed = 1
duration_s = 60
[[agents]]
program = "waypoint"
args = ["--waypoints", "5,5"]
"""


@pytest.fixture
def scenario(tmp_path: Path) -> Path:
    (tmp_path / "lab.xml").write_text('<Lab Name="hall" Width="20" Height="10"/>')
    (tmp_path / "s.toml").write_text(TOML)
    return tmp_path / "s.toml"


def test_seed_and_sets_change_the_scenario_the_seed_last(scenario: Path) -> None:
    args = build_parser().parse_args(
        [str(scenario), "--set", "world.seed=4", "--seed", "9", "--set", 'agents[0].args=["--waypoints", "6,5"]']
    )
    sc = load_scenario(scenario, scenario_sets(args))
    assert sc.world.seed == 9
    assert sc.agents[0].args == ("--waypoints", "6,5")


def test_a_set_not_of_the_form_is_refused_by_the_parser(scenario: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args([str(scenario), "--set", "world.seed"])
    assert e.value.code == 2
    assert "FIELD=VALUE" in capsys.readouterr().err


def test_a_refused_field_ends_iwz_run_before_anything_starts(
    scenario: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert launcher.main([str(scenario), "--set", "world.duration_s=-5", "--no-record"]) == 2
    out = capsys.readouterr().out
    assert "world.duration_s" in out
    assert "iwz run:" in out
