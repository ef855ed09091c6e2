"""A robot's spec as data: spec files and scenario tables laid over a chair, checked as a
registration is, refused with the field's path."""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

import msgspec
import pytest

from iw_zenoh.agent.programs import add_spec_arguments, find_program, make_with_spec
from iw_zenoh.convert import spec_to_msg
from iw_zenoh.core.spec import RobotSpec, prototype_chair
from iw_zenoh.errors import ConfigError
from iw_zenoh.messages import RobotSpecMsg, SensorNoiseMsg
from iw_zenoh.scenario.file import parse_scenario
from iw_zenoh.scenario.specfile import apply_spec, load_spec_file

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "maps" / "chair.toml"


def test_a_table_changes_only_the_fields_it_gives() -> None:
    base = prototype_chair("c")
    spec = apply_spec(base, {"max_speed_mps": 0.8, "noise": {"gps_m": {"std": 0.1}}})
    assert spec.max_speed_mps == 0.8
    assert spec.noise.gps_m.std == 0.1
    assert spec.noise.gps_m.mean == base.noise.gps_m.mean  # a table is merged field by field
    assert spec.noise.compass_deg == base.noise.compass_deg
    assert spec.ir_sensors == base.ir_sensors
    assert (spec.width_m, spec.com, spec.name) == (base.width_m, base.com, "c")
    assert apply_spec(base, {}) is base


def test_a_laser_scanner_comes_through_a_table_like_any_sensor() -> None:
    spec = apply_spec(prototype_chair("c"), {"lasers": [{"id": 0, "beams": 32}], "noise": {"laser_m": {"std": 0.05}}})
    assert [(s.id, s.beams, s.fov_deg) for s in spec.lasers] == [(0, 32, 270.0)]
    assert spec.noise.laser_m.std == 0.05


def test_a_chair_with_the_default_sensors_keeps_them_placed_on_its_new_body() -> None:
    spec = apply_spec(RobotSpec("c"), {"width_m": 2.0, "com": 0.75})
    assert spec.ir_sensors == ()
    assert spec.sensors[0].x_m == 1.5  # the front sensor at the new front


def test_a_list_replaces_the_chairs_whole_and_noise_false_switches_every_noise_off() -> None:
    spec = apply_spec(prototype_chair("c"), {"ir_sensors": [{"id": 4, "cone_deg": 5.0}], "noise": False})
    assert [(s.id, s.cone_deg, s.range_m) for s in spec.ir_sensors] == [(4, 5.0, 4.0)]
    noise = msgspec.structs.asdict(spec_to_msg(spec).noise)  # type: ignore[arg-type]
    assert set(noise) == set(SensorNoiseMsg.__struct_fields__)
    assert not any(n.enabled for n in noise.values())


@pytest.mark.parametrize(
    ("table", "path", "reason"),
    [
        ({"width_m": -1.0}, "width_m", "must be > 0, got -1.0"),
        ({"com": 1.0}, "com", "must be in ]0;1[, got 1.0"),
        ({"acceleration_curve": 0.0}, "acceleration_curve", "must be in ]0;1], got 0.0"),
        ({"ticks_per_m": 0}, "ticks_per_m", "must be > 0, got 0.0"),
        ({"ir_sensors": [{"id": 0}, {"id": 1}, {"id": 2, "range_m": 0.0}]}, "ir_sensors[2].range_m", "must be > 0"),
        ({"ir_sensors": [{"id": 3, "cone_deg": 180}]}, "ir_sensors[0].cone_deg", "must be in ]0;180[, got 180.0"),
        ({"ir_sensors": [{"id": 3, "angle_deg": 270}]}, "ir_sensors[0].angle_deg", "must be in [-180;180]"),
        ({"ir_sensors": [{"x_m": 0.3}]}, "ir_sensors[0].id", "is required"),
        ({"noise": {"gps_m": {"std": -0.5}}}, "noise.gps_m.std", "must be >= 0, got -0.5"),
        ({"noise": {"gps_m": {"sdt": 1}}}, "noise.gps_m.sdt", "unknown field"),
        ({"wheels": 3}, "wheels", "unknown field"),
        ({"width_m": "wide"}, "width_m", "Expected `float`, got `str`"),
        ({"shape": "hexagon"}, "shape", "Invalid enum value 'hexagon'"),
        ({"bumpers": [{"id": 0, "corners": [[0, 0], [1, 0]]}]}, "bumpers[0]", "needs at least 3 corners"),
        ({"max_speed_mps": float("inf")}, "max_speed_mps", "must be a finite number"),
        ({"lasers": [{"id": 0, "fov_deg": 400.0}]}, "lasers[0].fov_deg", "must be in ]0;360], got 400.0"),
        ({"lasers": [{"id": 0, "beams": 0}]}, "lasers[0].beams", ">= 1"),
    ],
)
def test_a_bad_field_is_refused_with_its_path_as_a_registration_would_be(table, path: str, reason: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ConfigError) as e:
        apply_spec(prototype_chair("c"), table, where="robots[0].spec")
    assert e.value.field == f"robots[0].spec.{path}"
    assert reason in e.value.reason


def test_the_example_spec_file_loads_and_a_bad_file_is_refused_naming_it(tmp_path: Path) -> None:
    spec = apply_spec(RobotSpec("x"), load_spec_file(EXAMPLE))
    assert (spec.width_m, spec.height_m, spec.com, spec.acceleration_curve) == (1.04, 0.66, 0.81, 0.2)
    assert len(spec.ir_sensors) == 8
    assert len(spec.bumpers) == 1
    bad = tmp_path / "bad.toml"
    for text, said in [
        ("width_m = 1\n", "width_m: not under [chair]"),
        ("", "no [chair] table"),
        ("[chair]\nwidth_m = 1\n[robot]\n", "robot: not under [chair]"),
        ("[chair\n", "not a TOML file"),
    ]:
        bad.write_text(text)
        with pytest.raises(ConfigError, match=re.escape(said)):
            load_spec_file(bad)
    with pytest.raises(ConfigError, match="cannot read it"):
        load_spec_file(tmp_path / "gone.toml")


def test_a_scenario_reads_its_agents_spec_file_or_table_and_refuses_a_bad_one(tmp_path: Path) -> None:
    (tmp_path / "m.xml").write_text('<Lab Name="m" Width="10" Height="5"></Lab>')
    (tmp_path / "chair.toml").write_text(EXAMPLE.read_text())
    head = '[world]\nmap = "m.xml"\n'
    sc = parse_scenario(
        head + '[[agents]]\nprogram = "waypoint"\nspec = "chair.toml"\n'
        '[[agents]]\nprogram = "waypoint"\nspec = { width_m = 1.2, noise = false }\n',
        tmp_path,
    )
    assert sc.agents[0].spec == load_spec_file(EXAMPLE)
    assert sc.agents[1].spec == {"width_m": 1.2, "noise": False}
    bad = (
        head
        + '[[agents]]\nprogram = "x"\n[[agents]]\nprogram = "y"\nspec = { ir_sensors = [{ id = 0 }, { id = 1, range_m = -2 }] }\n'
    )
    with pytest.raises(ConfigError) as e:
        parse_scenario(bad, tmp_path)
    assert str(e.value) == "agents[1].spec.ir_sensors[1].range_m: must be > 0, got -2.0"
    with pytest.raises(ConfigError, match=r"agents\[0\].spec: .*gone.toml does not exist"):
        parse_scenario(head + '[[agents]]\nprogram = "x"\nspec = "gone.toml"\n', tmp_path)


def test_iwz_agent_spec_changes_the_chair_a_program_builds_and_a_users_agent_registers(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine.py").write_text(
        "from iw_zenoh.agent import Command\nfrom iw_zenoh.core.spec import RobotSpec\n"
        "class Mine:\n    def spec(self):\n        return RobotSpec('mine', width_m=2.0)\n"
        "    def on_sensors(self, reading, heard):\n        return Command()\n"
        "    def on_registered(self, robot_id, spec):\n        self.got = (robot_id, spec.width_m)\n"
    )
    for name, argv in [("waypoint", ["--waypoints", "5,5"]), ("./mine.py:Mine", [])]:
        program = find_program(name)
        p = argparse.ArgumentParser()
        program.add_arguments(p)
        add_spec_arguments(p)
        args = p.parse_args([*argv, "--spec", str(EXAMPLE), "--spec-json", json.dumps({"max_speed_mps": 0.9})])
        (agent,) = make_with_spec(program, args)
        spec = agent.spec()
        assert (spec.width_m, spec.max_speed_mps, len(spec.ir_sensors)) == (1.04, 0.9, 8)
        if name == "waypoint":  # the program built its chair from the table: it drives what it registers
            assert agent._angles[2] == 90.0  # type: ignore[attr-defined]
    agent.on_registered(3, spec)  # type: ignore[attr-defined]  # the user's agent's own hook, through
    assert agent.got == (3, 1.04)  # type: ignore[attr-defined]


def test_docs_spec_names_every_registration_field_and_noise_kind() -> None:
    text = (ROOT / "docs" / "spec.md").read_text()
    for field in RobotSpecMsg.__struct_fields__:
        assert f"`{field}`" in text, f"docs/spec.md does not name {field}"
    for kind in SensorNoiseMsg.__struct_fields__:
        assert f"| `{kind}` |" in text, f"docs/spec.md has no row for noise {kind}"


def test_iwz_run_hands_a_scenarios_spec_to_its_agent_and_to_the_serial_chair(tmp_path: Path) -> None:
    from iw_zenoh.launch.launcher import Launcher

    (tmp_path / "m.xml").write_text('<Lab Name="m" Width="10" Height="5"></Lab>')
    (tmp_path / "chair.toml").write_text(EXAMPLE.read_text())
    sc = parse_scenario(
        '[world]\nmap = "m.xml"\n[chair]\nspec = "chair.toml"\n'
        '[[agents]]\nprogram = "waypoint"\nspec = { width_m = 1.2 }\n',
        tmp_path,
    )
    launcher = Launcher(sc, port=1, log_dir=tmp_path / "logs", record=None)
    launcher.plan()
    argv = {c.name: c.argv for c in launcher.children}
    agent = argv["agent-1-waypoint"]
    assert json.loads(agent[agent.index("--spec-json") + 1]) == {"width_m": 1.2}
    for name in ("chair", "bridge-serial"):
        assert argv[name][argv[name].index("--spec") + 1] == str(tmp_path / "chair.toml")
