from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Annotated

import msgspec
import pytest

from iw_zenoh.errors import ConfigError, IwError
from iw_zenoh.launch.launcher import Launcher, world_options
from iw_zenoh.messages import Obstacle
from iw_zenoh.nodes.world import world_config
from iw_zenoh.nodes.world_options import WorldOptions, add_arguments
from iw_zenoh.process.options import add_option_flags, add_options_argument, declared_flags, options_from_args
from iw_zenoh.scenario.file import load_scenario
from iw_zenoh.sim.config import WorldConfig, WorldSettings

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
    cfg = world_config(WorldOptions(map="m.xml", period_ms=50, duration_s=2.0, mode="lockstep"), "s")  # type: ignore[arg-type]
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


# ---- the flags generated from the declaration (WorldSettings, WorldOptions) ----------------------

# (field, action, type, choices, const, metavar, help): the hand table the flags were before
# fmt: off
OLD_FLAGS = {
    "--grid": ("grid", "_StoreAction", None, None, None, 'FILE', 'Grid XML file of start positions (default: none; robots give X, Y)'),
    "--period-ms": ("period_ms", "_StoreAction", 'float', None, None, 'MS', 'tick period in ms (default 100; Ciber-Rato uses 50)'),
    "--lockstep": ("mode", "_StoreConstAction", None, None, 'lockstep', None, "lock-step: wait for every live agent's actions each tick (default: real time)"),
    "--profile": ("profile", "_StoreAction", None, ['native', 'ciberrato'], None, None, 'motion and collision rules (default native)'),
    "--seed": ("seed", "_StoreAction", 'int', None, None, 'N', 'seed of movement noise (default 0)'),
    "--action-timeout-ms": ("action_timeout_ms", "_StoreAction", 'float', None, None, 'MS', "zero a robot's motors when its actions are older, if silence stops it (default 500)"),
    "--silence": ("silence", "_StoreAction", None, ['stop', 'keep'], None, None, "what a robot whose actions stop coming does: stop (its motors zeroed after --action-timeout-ms) or keep (its last command for ever, as the legacy simulator); default: the profile's, native stop, ciberrato keep"),
    "--grace-ms": ("grace_ms", "_StoreAction", 'float', None, None, 'MS', 'remove a robot this long after its agent is gone (default 5000)'),
    "--lockstep-timeout-ms": ("lockstep_timeout_ms", "_StoreAction", 'float', None, None, 'MS', "lock-step: wait this long for a tick's actions (default 2000)"),
    "--expect": ("expect", "_StoreAction", 'int', None, None, 'N', 'wait for this many robots before the first tick (default 0)'),
    "--duration": ("duration_s", "_StoreAction", 'float', None, None, 'S', 'stop after this many simulated seconds (default: run until stopped)'),
    "--paused": ("start_paused", "_StoreTrueAction", None, None, True, None, "start paused; a 'start' control runs it"),
    "--motors-noise": ("motors_noise_pct", "_StoreAction", 'float', None, None, 'PCT', 'Ciber-Rato MotorsNoise, percent (legacy profile)'),
    "--policy": ("owners", "_StoreAction", '_owners_flag', None, None, 'TOML', "a secured run's policy: each agent registers only its own robots, and only under its own name"),
    "--obstacle": ("obstacles", "_AppendAction", '_obstacle_flag', None, None, 'NAME:X0,Y0,X1,Y1[,H]', 'a rectangular obstacle from the start (repeatable)'),
}
# fmt: on

RANGES = {  # what each flag's help now adds: the range its field declares
    "--period-ms": " (1 to 60000)",
    "--seed": " (at least 0)",
    "--action-timeout-ms": " (more than 0, at most 86400000)",
    "--grace-ms": " (0 to 86400000)",
    "--lockstep-timeout-ms": " (more than 0, at most 86400000)",
    "--duration": " (0 to 604800)",
    "--motors-noise": " (0 to 100)",
}


def test_every_world_flag_is_generated_from_its_field_as_the_hand_table_spelled_it() -> None:
    p = argparse.ArgumentParser()
    add_arguments(p)
    got = {
        a.option_strings[0]: (
            a.dest.removeprefix("option:"),
            type(a).__name__,
            getattr(a.type, "__name__", a.type),
            a.choices,
            a.const,
            a.metavar,
            a.help,
        )
        for a in p._actions
        if a.option_strings and a.dest.startswith("option:")
    }
    want = {flag: (*how[:-1], how[-1] + RANGES.get(flag, "")) for flag, how in OLD_FLAGS.items()}
    assert got == want
    assert {f[1] for f in declared_flags(WorldOptions)} == {how[0] for how in OLD_FLAGS.values()}


class _Tomorrow(WorldOptions, frozen=True, kw_only=True):
    """A setting added tomorrow: one line."""

    turn_limit_deg: Annotated[float, msgspec.Meta(ge=0, le=180, description="turn at most (default {default:g})")] = 90


def test_a_new_setting_is_one_line_and_gets_its_flag_help_and_range() -> None:
    p = argparse.ArgumentParser()
    add_option_flags(p, _Tomorrow, declared_flags(_Tomorrow))
    assert "turn at most (default 90) (0 to 180)" in " ".join(p.format_help().split())
    assert options_from_args(p.parse_args(["--turn-limit-deg", "45"]), _Tomorrow).turn_limit_deg == 45.0
    with pytest.raises(IwError, match=r"turn_limit_deg"):
        options_from_args(p.parse_args(["--turn-limit-deg", "200"]), _Tomorrow)


def test_the_world_core_config_is_the_settings_with_one_set_of_defaults() -> None:
    assert issubclass(WorldConfig, WorldSettings)
    shared = WorldSettings.__struct_fields__
    assert all(getattr(WorldConfig(), f) == getattr(WorldSettings(), f) == getattr(WorldOptions(), f) for f in shared)
    changed = {
        "period_ms": 50.0,
        "mode": "lockstep",
        "profile": "ciberrato",
        "seed": 7,
        "action_timeout_ms": 900.0,
        "grace_ms": 10.0,
        "lockstep_timeout_ms": 60000.0,
        "motors_noise_pct": 1.5,
        "silence": "keep",
        "start_paused": True,
    }
    assert set(changed) == set(shared)  # a new setting: add it here too
    cfg = world_config(msgspec.convert({"map": "m.xml", **changed}, WorldOptions), "s")
    assert {f: getattr(cfg, f) for f in shared} == changed
