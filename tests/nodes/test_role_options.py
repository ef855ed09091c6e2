"""Each role ``iwz run`` configures takes its options as one typed Struct: its flags and its
``--options JSON`` give the same one, a malformed one is refused naming the field (exit 2), and
the launcher's plan hands every role its Struct."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path

import msgspec
import pytest
from iw_zenoh.bridges.ciberrato import app as bridge_app
from iw_zenoh.bridges.ciberrato.options import add_arguments as add_bridge_arguments

from iw_zenoh.errors import IwError
from iw_zenoh.launch.launcher import Launcher
from iw_zenoh.nodes import radio, recorder
from iw_zenoh.nodes.role_options import (
    BridgeOptions,
    RadioOptions,
    RecorderOptions,
    SensorsOptions,
    add_radio_arguments,
    add_recorder_arguments,
    add_sensors_arguments,
)
from iw_zenoh.nodes.world_options import WorldOptions
from iw_zenoh.process.options import options_from_args, options_json
from iw_zenoh.scenario.file import load_scenario
from iw_zenoh.sim.radio import RadioConfig

MAPS = Path(__file__).resolve().parents[2] / "maps"

Adder = Callable[[argparse.ArgumentParser], None]

# each role: how its flags are added, its Struct, flags, and the same options as JSON
ROLES: list[tuple[Adder, type[msgspec.Struct], list[str], dict[str, object]]] = [
    (add_sensors_arguments, SensorsOptions, ["--shard", "2/3", "--no-ahead"], {"shard": [2, 3], "ahead": False}),
    (
        add_radio_arguments,
        RadioOptions,
        ["--range", "4", "--max-bytes", "50", "--budget", "200"],
        {"range_m": 4.0, "max_message_bytes": 50, "max_heard_bytes": 200},
    ),
    (
        add_recorder_arguments,
        RecorderOptions,
        ["-o", "r.mcap", "--meta", "scenario=demo", "--meta", "seed=1", "--quiet", "--continue", "run-1"],
        {"output": "r.mcap", "meta": {"scenario": "demo", "seed": "1"}, "quiet": True, "continue_run": "run-1"},
    ),
    (
        add_bridge_arguments,
        BridgeOptions,
        ["--port", "6001", "--param", "p.xml", "--scoring", "1", "--pace", "off", "--bind", "0.0.0.0"],
        {"port": 6001, "param": "p.xml", "scoring": 1, "pace": "off", "bind": "0.0.0.0"},
    ),
]


def _parse(add: Adder, *argv: str) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    add(p)
    return p.parse_args(argv)


@pytest.mark.parametrize(("add", "kind", "flags", "as_json"), ROLES, ids=lambda v: getattr(v, "__name__", ""))
def test_a_roles_flags_and_its_options_give_the_same_struct(
    add: Adder, kind: type[msgspec.Struct], flags: list[str], as_json: dict[str, object]
) -> None:
    from_flags = options_from_args(_parse(add, *flags), kind)
    from_json = options_from_args(_parse(add, "--options", json.dumps(as_json)), kind)
    assert from_flags == from_json == msgspec.convert(as_json, kind)
    assert from_flags != kind()  # every flag was read
    assert options_from_args(_parse(add), kind) == kind()  # none given: the defaults
    again = options_from_args(_parse(add, "--options", options_json(from_flags)), kind)
    assert again == from_flags  # what iwz run passes decodes back to the same


@pytest.mark.parametrize(
    ("add", "kind", "options", "field"),
    [
        (add_sensors_arguments, SensorsOptions, '{"shard": [3, 2]}', "K must not exceed N"),
        (add_sensors_arguments, SensorsOptions, '{"shard": [0, 2]}', "$.shard[0]"),
        (add_radio_arguments, RadioOptions, '{"range_m": 0}', "$.range_m"),
        (add_radio_arguments, RadioOptions, '{"budget": 10}', "budget"),
        (add_recorder_arguments, RecorderOptions, '{"quiet": "yes"}', "$.quiet"),
        (add_recorder_arguments, RecorderOptions, '{"meta": {"": "x"}}', "$.meta"),
        (add_bridge_arguments, BridgeOptions, '{"port": 70000}', "$.port"),
        (add_bridge_arguments, BridgeOptions, '{"scoring": 4}', "$.scoring"),
        (add_bridge_arguments, BridgeOptions, '{"pace": "fast"}', "$.pace"),
    ],
)
def test_a_malformed_options_is_refused_naming_the_field(
    add: Adder, kind: type[msgspec.Struct], options: str, field: str
) -> None:
    with pytest.raises(IwError, match="refused options") as e:
        options_from_args(_parse(add, "--options", options), kind)
    assert field in str(e.value)


@pytest.mark.parametrize(
    ("main", "argv", "field"),
    [
        (radio.main, ["--options", '{"max_heard_bytes": -1}'], "$.max_heard_bytes"),
        (recorder.main, ["--options", '{"output": 3}'], "$.output"),
        (bridge_app.main, ["ciberrato", "--options", '{"port": "x"}'], "$.port"),
    ],
    ids=["radio", "record", "bridge"],
)
def test_a_role_given_malformed_options_exits_2_saying_why(
    main: Callable[[list[str]], int], argv: list[str], field: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2  # refused before it joins any bus
    out = capsys.readouterr().out
    assert "refused options" in out
    assert field in out


def test_a_flag_beside_options_overrides_it() -> None:
    args = _parse(add_radio_arguments, "--options", '{"range_m": 4, "max_heard_bytes": 200}', "--range", "6")
    assert options_from_args(args, RadioOptions) == RadioOptions(range_m=6.0, max_heard_bytes=200)


def test_the_radio_options_default_to_the_radio_logics_limits() -> None:
    d, c = RadioOptions(), RadioConfig()
    assert (d.range_m, d.max_message_bytes, d.max_heard_bytes) == (c.range_m, c.max_message_bytes, c.max_heard_bytes)


def _options_of(argv: list[str], kind: type[msgspec.Struct]) -> msgspec.Struct:
    return msgspec.json.decode(argv[argv.index("--options") + 1], type=kind)


def test_the_launchers_plan_hands_each_role_its_options_as_a_struct(tmp_path: Path) -> None:
    sc = load_scenario(MAPS / "scenarios" / "ciberrato-c1.toml")
    sc = msgspec.structs.replace(sc, roles=msgspec.structs.replace(sc.roles, sensors_shards=2))
    launcher = Launcher(sc, port=7447, log_dir=tmp_path, status=False, record=tmp_path / "run.mcap")
    launcher.plan()
    by_name = {c.name: c for c in launcher.children}
    kinds = {"record": RecorderOptions, "world": WorldOptions, "sensors": SensorsOptions, "radio": RadioOptions}
    kinds["bridge"] = BridgeOptions
    for c in launcher.children:
        if c.role in kinds:
            assert isinstance(c.options, kinds[c.role]), c.name
            assert _options_of(c.argv, kinds[c.role]) == c.options  # in its command line, whole
        else:
            assert c.options is None, c.name  # router, collision, agents
            assert "--options" not in c.argv, c.name
    rec = by_name["recorder"].options
    assert isinstance(rec, RecorderOptions)
    assert (rec.output, rec.quiet, rec.meta["scenario"]) == (str(tmp_path / "run.mcap"), True, "ciberrato-c1")
    assert rec.continue_run  # the run's id: a restarted recorder continues this recording
    assert [by_name[f"sensors-{k}"].options for k in (1, 2)] == [
        SensorsOptions(shard=(1, 2)),
        SensorsOptions(shard=(2, 2)),
    ]
    assert by_name["radio"].options == RadioOptions()
    bridge = by_name["bridge"]
    assert bridge.options == BridgeOptions(port=6000, param=str(sc.bridge.params) if sc.bridge else "", scoring=1)
    assert bridge.argv[bridge.argv.index("bridge") + 1] == "ciberrato"
    assert not {"--shard", "--port", "--scoring", "--param", "-o", "--meta"} & {
        a for c in launcher.children for a in c.argv
    }
