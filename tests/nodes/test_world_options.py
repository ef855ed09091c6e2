from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from iw_zenoh.errors import ConfigError, IwError
from iw_zenoh.launch.launcher import Launcher, world_options
from iw_zenoh.messages import Obstacle
from iw_zenoh.nodes.world import world_config
from iw_zenoh.nodes.world_options import WorldOptions, add_arguments
from iw_zenoh.process.options import add_options_argument, options_from_args
from iw_zenoh.scenario.file import load_scenario

MAPS = Path(__file__).resolve().parents[2] / "maps"


def _parse(*argv: str) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    add_arguments(p)
    return p.parse_args(argv)


def test_world_flags_fill_the_options() -> None:
    opts = options_from_args(
        _parse("m.xml", "--lockstep", "--period-ms", "50", "--obstacle", "A:1,2,3,4"), WorldOptions
    )
    assert opts.map == "m.xml"
    assert opts.mode == "lockstep"
    assert opts.period_ms == 50.0
    assert opts.obstacles == (Obstacle(name="A", x0=1, y0=2, x1=3, y1=4),)
    assert opts.seed == WorldOptions().seed


def test_flags_given_beside_options_override_them() -> None:
    args = _parse("--options", json.dumps({"map": "m.xml", "seed": 3, "period_ms": 50}), "--seed", "9")
    opts = options_from_args(args, WorldOptions)
    assert (opts.map, opts.seed, opts.period_ms) == ("m.xml", 9, 50.0)


@pytest.mark.parametrize(
    ("options", "where"),
    [('{"period_ms": 0}', "$.period_ms"), ('{"mode": "fast"}', "$.mode"), ('{"speed": 1}', "speed"), ("{bad", "JSON")],
)
def test_malformed_options_are_refused_saying_where(options: str, where: str) -> None:
    with pytest.raises(IwError, match=r"refused options") as e:
        options_from_args(_parse("--options", options), WorldOptions)
    assert where in str(e.value)


def test_a_flag_out_of_range_is_refused() -> None:
    with pytest.raises(IwError, match=r"period_ms"):
        options_from_args(_parse("m.xml", "--period-ms", "-1"), WorldOptions)


def test_duration_becomes_ticks() -> None:
    cfg = world_config(WorldOptions(map="m.xml", period_ms=50, duration_s=2.0, mode="lockstep"), "s")
    assert (cfg.duration_ticks, cfg.mode, cfg.sim) == (40, "lockstep", "s")


def test_the_launcher_hands_the_world_the_scenario_as_options() -> None:
    sc = load_scenario(MAPS / "scenarios" / "demo.toml")
    opts, rest = world_options(sc)
    assert rest == []
    assert opts.map == str(sc.world.map)
    assert opts.expect == sc.robots == 3
    assert [o.name for o in opts.obstacles] == ["A", "B"]
    assert opts.duration_s == sc.world.duration_s


def test_world_args_are_read_into_the_options() -> None:
    sc = load_scenario(MAPS / "scenarios" / "ciberrato-c1.toml")
    opts, rest = world_options(sc)
    assert opts.motors_noise_pct == 1.5
    assert opts.profile == "ciberrato"
    assert rest == []


def test_a_bad_world_option_refuses_the_scenario(tmp_path: Path) -> None:
    (tmp_path / "s.toml").write_text(f'[world]\nmap = "{MAPS / "liacc.xml"}"\nmotors_noise_pct = "x"\n')
    with pytest.raises(ConfigError) as e:
        world_options(load_scenario(tmp_path / "s.toml"))
    assert "world.motors_noise_pct" in e.value.field


def test_the_world_child_gets_one_options_argument(tmp_path: Path) -> None:
    launcher = Launcher(load_scenario(MAPS / "scenarios" / "demo.toml"), port=7999, log_dir=tmp_path, status=False)
    launcher.plan()
    world = next(c for c in launcher.children if c.role == "world")
    at = world.argv.index("--options")
    sent = json.loads(world.argv[at + 1])
    assert sent["obstacles"][0]["name"] == "A"
    assert "--obstacle" not in world.argv


def test_options_argument_names_the_struct() -> None:
    p = argparse.ArgumentParser()
    add_options_argument(p, WorldOptions)
    assert "WorldOptions" in p.format_help()


def test_the_launcher_reserves_the_ids_the_scenario_gives_its_agents() -> None:
    opts, _ = world_options(load_scenario(MAPS / "scenarios" / "demo.toml"))
    assert opts.reserved == {"agent-1-waypoint": [2], "agent-2-waypoint": [1], "agent-3-waypoint": [4]}
    cfg = world_config(opts, "demo")
    assert cfg.reserved is not None
    assert cfg.reserved["agent-2-waypoint"] == (1,)
