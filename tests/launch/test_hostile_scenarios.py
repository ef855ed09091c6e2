"""Hostile scenario files are refused by ``iwz run`` before anything starts: exit 2, one line naming
the field, in words, fast. Deep nesting, numbers not finite or out of their documented range (a
1e308 ms period, a seed over 64 bits, a million sensors shards, a 1e308-metre lab, a 20-digit
criteria robot), paths that are no regular file (a directory, a FIFO, /dev/zero), names unsafe for
a file name. And the world's options reach it whatever their length (5,000 obstacles gave
"Argument list too long", 1,024 of them with long names too): long options go by file,
``--options @FILE``; more than the world takes are refused on reading."""

from __future__ import annotations

import argparse
import os
import subprocess
from pathlib import Path

import msgspec
import pytest

from iw_zenoh.errors import IwError
from iw_zenoh.launch.plan import RunPlan
from iw_zenoh.nodes.world_options import WorldOptions, add_arguments, world_options
from iw_zenoh.process.options import INLINE_MAX, options_argument, options_from_args
from iw_zenoh.scenario.file import load_scenario
from tests.integration.harness import iwz_run_argv, scenario_in, stop_run

pytestmark = [pytest.mark.timeout(120)]

HEAD = 'name = "hostile"\n[world]\nmap = "lab.xml"\ngrid = "grid.xml"\n'
AGENT = '[[agents]]\nprogram = "waypoint"\n'

# (case, scenario text after [world]'s map and grid, the field the refusal names, a word of its reason)
CASES = [
    ("deep nesting", f"args = {'[' * 3000}{']' * 3000}\n", "hostile", "nested"),
    ("nesting past the limit", f"args = {'[' * 40}{']' * 40}\n", "world.args", "nested"),
    ("a 1e308 ms period", "period_ms = 1e308\n", "world.period_ms", "<="),
    ("an infinite period", "period_ms = inf\n", "world.period_ms", "finite"),
    ("a NaN duration", "duration_s = nan\n", "world.duration_s", "finite"),
    ("a seed over 64 bits", "seed = 18446744073709551616\n", "world.seed", "64 bits"),
    ("a million sensors shards", "[roles]\nsensors_shards = 1000000\n", "roles.sensors_shards", "cores"),
    (
        "a 20-digit criteria robot",
        "[criteria]\n[[criteria.reach]]\nrobot = 99999999999999999999\nx_m = 1\ny_m = 1\n",
        "criteria.reach[0].robot",
        "64 bits",
    ),
    (
        "a criteria robot past 63 bits",
        "[criteria]\n[[criteria.reach]]\nrobot = 9223372036854775808\nx_m = 1\ny_m = 1\n",
        "criteria.reach[0].robot",
        "<=",
    ),
    ("a far goal", "[criteria]\n[[criteria.reach]]\nrobot = 1\nx_m = 1e300\ny_m = 1\n", "criteria.reach[0].x_m", "<="),
    ("a far obstacle", '[[obstacles]]\nname = "o"\nx0 = 1e308\ny0 = 0\nx1 = 1\ny1 = 1\n', "obstacles[0].x0", "within"),
    ("a slashed name", "", "hostile.name", "names files"),
    ("a long name", "", "hostile.name", "names files"),
    ("an agent named ../x", f'{AGENT}name = "../x"\n', "agents[0].name", "names files"),
    ("a million robots for one agent", f"{AGENT}robots = 1000000\n", "agents[0].robots", "<="),
]


def _scenario(tmp: Path, case: str, body: str) -> Path:
    text = HEAD + body
    if case == "a slashed name":
        text = text.replace('name = "hostile"', 'name = "a/b/../../c"')
    if case == "a long name":
        text = text.replace('name = "hostile"', f'name = "{"n" * 300}"')
    return scenario_in(tmp, "hostile", text)


def _refused(scenario: Path, tmp: Path) -> tuple[int, str]:
    """``iwz run SCENARIO``'s exit code and what it said (stopped if it started)."""
    p = subprocess.Popen(
        iwz_run_argv(scenario, tmp / "logs", "hostile"), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        out, err = p.communicate(timeout=20)
    except subprocess.TimeoutExpired:  # it started a run: stop it and everything it started
        out, err = stop_run(p)
    return p.returncode, (out + err).strip()


def _assert_refused(scenario: Path, tmp: Path, field: str, word: str) -> None:
    code, said = _refused(scenario, tmp)
    assert code == 2, said
    assert len(said.splitlines()) == 1, said
    assert f": {field}: " in said or f": {field}[" in said, said
    assert word in said, said
    assert "Traceback" not in said, said
    assert "Error:" not in said, said
    assert not (tmp / "logs").exists() or not any((tmp / "logs").iterdir()), "a role was started"


@pytest.mark.parametrize(("case", "body", "field", "word"), CASES, ids=[c[0] for c in CASES])
def test_iwz_run_refuses_a_hostile_scenario_with_exit_2_naming_the_field(
    tmp_path: Path, case: str, body: str, field: str, word: str
) -> None:
    _assert_refused(_scenario(tmp_path, case, body), tmp_path, field, word)


@pytest.mark.parametrize("what", ["a directory", "a FIFO", "/dev/zero", "a 1e308-metre lab"])
def test_a_map_that_is_no_regular_readable_file_is_refused_as_what_it_is(tmp_path: Path, what: str) -> None:
    sc = scenario_in(tmp_path, "hostile", HEAD)
    lab = tmp_path / "lab.xml"
    lab.unlink()
    word = {"a directory": "directory", "a FIFO": "FIFO", "/dev/zero": "device"}.get(what, "")
    if what == "a directory":
        lab.mkdir()
    elif what == "a FIFO":
        os.mkfifo(lab)
    elif what == "/dev/zero":
        lab.symlink_to("/dev/zero")
    else:  # tests run as root (CI too), who reads any file: an unreadable map cannot be made here
        lab.write_text('<Lab Name="huge" Width="1e308" Height="10"/>')
        word = "Width"
    _assert_refused(sc, tmp_path, "world.map", word)


def test_a_grid_that_is_a_directory_is_refused_naming_the_grid(tmp_path: Path) -> None:
    sc = scenario_in(tmp_path, "hostile", HEAD)
    (tmp_path / "grid.xml").unlink()
    (tmp_path / "grid.xml").mkdir()
    _assert_refused(sc, tmp_path, "world.grid", "directory")


def _obstacles(n: int) -> str:
    """``n`` obstacles in the open lab, long names and long numbers: over 128 KiB of options."""
    return "".join(
        f'[[obstacles]]\nname = "{i:04d}{"n" * 60}"\nx0 = {1 + (i % 32) * 0.5 + 1e-9 * i!r}\n'
        f"y0 = {1 + (i // 32) * 0.25 + 1e-9 * i!r}\nx1 = {1.1 + (i % 32) * 0.5 + 1e-9 * i!r}\n"
        f"y1 = {1.1 + (i // 32) * 0.25 + 1e-9 * i!r}\n"
        for i in range(n)
    )


def test_more_obstacles_than_the_world_takes_are_refused_naming_the_first_too_many(tmp_path: Path) -> None:
    body = "[roles]\nradio = false\n" + _obstacles(1025)
    _assert_refused(scenario_in(tmp_path, "hostile", HEAD + body), tmp_path, "obstacles[1024]", "the most it takes")


def test_the_options_of_a_world_of_1024_obstacles_go_by_file_and_reach_it_whole(tmp_path: Path) -> None:
    sc = load_scenario(scenario_in(tmp_path, "many", HEAD + _obstacles(1024)))
    plan = RunPlan(
        sc, world_options(sc), sim="many", listen="tcp/127.0.0.1:1", endpoint="tcp/127.0.0.1:1", log_dir=tmp_path
    )
    world = next(c for c in plan.build() if c.role == "world")
    assert len(msgspec.json.encode(world.options)) > 128 * 1024  # past what one argument may hold
    assert max(len(a) for a in world.argv) <= INLINE_MAX
    given = world.argv[world.argv.index("--options") + 1]
    assert given.startswith("@")
    assert _world_options(["--options", given]) == world.options
    assert len(world.options.obstacles) == 1024


@pytest.mark.zenoh
def test_a_lockstep_run_of_1024_obstacles_starts_its_world_and_ends(tmp_path: Path) -> None:
    body = 'mode = "lockstep"\nduration_s = 1\n[roles]\nradio = false\n' + _obstacles(1024)
    sc = scenario_in(tmp_path, "many", HEAD.replace('grid = "grid.xml"\n', "") + body)
    p = subprocess.Popen(
        iwz_run_argv(sc, tmp_path / "logs", "many"), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        out, err = p.communicate(timeout=90)
    except subprocess.TimeoutExpired:
        out, err = stop_run(p)
    assert p.returncode == 0, out + err
    assert "ended at t=1.0 s" in out, out + err
    assert (tmp_path / "logs" / "world.options.json").stat().st_size > 128 * 1024


def _world_options(argv: list[str]) -> WorldOptions:
    """The options ``iwz world`` reads from its command line."""
    p = argparse.ArgumentParser()
    add_arguments(p)
    return options_from_args(p.parse_args(argv), WorldOptions)


def test_short_options_stay_on_the_command_line(tmp_path: Path) -> None:
    assert (
        options_argument(WorldOptions(map="m.xml"), tmp_path / "w.json")
        == msgspec.json.encode(WorldOptions(map="m.xml")).decode()
    )
    assert not (tmp_path / "w.json").exists()
    with pytest.raises(IwError, match="cannot read it"):
        _world_options(["--options", "@/nonexistent/x.json"])
