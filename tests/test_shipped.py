"""The scenarios, maps and sample recording that ship with the package (iw_zenoh.scenario.shipped)."""

from __future__ import annotations

from pathlib import Path

import pytest

from iw_zenoh.cli import main as iwz
from iw_zenoh.errors import ConfigError
from iw_zenoh.scenario import shipped
from iw_zenoh.scenario.file import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def test_every_scenario_of_the_repository_ships_and_has_a_summary() -> None:
    found = {s.name: s for s in shipped.scenarios()}
    assert set(found) == {p.stem for p in (ROOT / "maps" / "scenarios").glob("*.toml")}
    assert {"demo", "slalom", "hospital", "ciberrato-c1"} <= set(found)
    assert all(s.summary and len(s.summary) <= 150 for s in found.values())
    assert found["negotiated-door"].summary.startswith("Two autonomous chairs, one from each side")


@pytest.mark.parametrize("name", sorted(p.stem for p in (ROOT / "maps" / "scenarios").glob("*.toml")))
def test_every_shipped_scenario_loads_with_its_maps(name: str) -> None:
    sc = load_scenario(shipped.resolve_scenario(name))
    assert sc.world.map.is_file()
    assert ".." not in sc.world.map.parts  # folded: errors and messages name maps/X, not maps/scenarios/../X


def test_a_name_is_a_shipped_scenario_and_a_path_stays_a_path(tmp_path: Path) -> None:
    assert shipped.resolve_scenario("demo") == shipped.data_dir() / "scenarios" / "demo.toml"
    mine = tmp_path / "demo.toml"
    assert shipped.resolve_scenario(str(mine)) == mine  # a path is never looked up by name
    with pytest.raises(ConfigError, match=r"nosuch: no such file, and no shipped scenario.*demo, "):
        shipped.resolve_scenario("nosuch")


def test_a_copied_scenario_runs_from_its_folder_with_every_file_it_names(tmp_path: Path) -> None:
    written = shipped.copy_scenario("hospital", tmp_path / "mine")
    assert written[0] == tmp_path / "mine" / "hospital.toml"
    assert [p.name for p in written[1:]] == ["hospital.xml"]  # it names no grid: its agents give their starts
    sc = load_scenario(written[0])
    assert sc.world.map == tmp_path / "mine" / "hospital.xml"
    assert all("--map" not in a.args or a.args[a.args.index("--map") + 1] == "hospital.xml" for a in sc.agents)
    with pytest.raises(ConfigError, match="already exists"):
        shipped.copy_scenario("hospital", tmp_path / "mine")
    with pytest.raises(ConfigError, match="not a shipped scenario"):
        shipped.copy_scenario("../maps/liacc", tmp_path / "other")


def test_a_copied_legacy_scenario_keeps_its_folders(tmp_path: Path) -> None:
    written = shipped.copy_scenario("ciberrato-c1", tmp_path)
    assert {p.relative_to(tmp_path).as_posix() for p in written[1:]} == {
        "ciberrato/C1-config.xml",
        "ciberrato/C1-grid.xml",
        "ciberrato/C1-lab.xml",
    }
    sc = load_scenario(written[0])
    assert sc.bridge is not None
    assert sc.bridge.params == tmp_path / "ciberrato" / "C1-config.xml"


def test_iwz_scenarios_lists_copies_and_names_the_sample(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert iwz(["scenarios"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0].startswith("automatic-door ")
    assert "demo" in out
    assert "iwz scenarios copy NAME DIR" in out
    assert iwz(["scenarios", "sample"]) == 0
    sample = Path(capsys.readouterr().out.strip())
    assert sample.name == "demo-sample.mcap"
    assert sample.read_bytes()[:8] == b"\x89MCAP0\r\n"
    assert iwz(["scenarios", "copy", "nosuch", str(tmp_path)]) == 2
    assert "not a shipped scenario" in capsys.readouterr().err


def test_a_scenario_naming_a_file_outside_the_shipped_folder_copies_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    data = tmp_path / "data"
    (data / "scenarios").mkdir(parents=True)
    (tmp_path / "secret.xml").write_text("<Lab/>")
    (data / "scenarios" / "sly.toml").write_text('[world]\nmap = "../../secret.xml"\n')
    monkeypatch.setattr(shipped, "data_dir", lambda: data)
    with pytest.raises(ConfigError, match="names no shipped file"):
        shipped.copy_scenario("sly", tmp_path / "out")
    assert not (tmp_path / "out").exists()
