"""Agent programs from the user's own file: found, loaded and made, or refused saying what and
where (real files, no bus)."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from iw_zenoh.agent.programs import ProgramError, find_program, is_file_program, program_label

AGENT = '''"""Goes forward."""
from iw_zenoh.agent import Command
from iw_zenoh.core.spec import RobotSpec


def add_arguments(parser):
    parser.add_argument("--power", type=float, default=0.1)


class Forward:
    def __init__(self, args):
        self.power = args.power

    def spec(self):
        return RobotSpec("fwd")

    def on_sensors(self, reading, heard):
        return Command(self.power, self.power)


class Still:
    def spec(self):
        return RobotSpec("still")

    def on_sensors(self, reading, heard):
        return Command()


def make(args):
    return [Forward(args), Still()]


ready = Still()
number = 3


def text():
    return "no agent"


class BadSpec(Still):
    def spec(self):
        return RobotSpec("bad", width_m=-1.0)
'''
BAD_LINE = AGENT.splitlines().index('        return RobotSpec("bad", width_m=-1.0)') + 1


@pytest.fixture
def agent_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    f = tmp_path / "mine.py"
    f.write_text(AGENT)
    return f


def _made(text: str, *argv: str) -> list[object]:
    program = find_program(text)
    p = argparse.ArgumentParser()
    program.add_arguments(p)
    return list(program.make(p.parse_args(list(argv))))


def test_a_file_names_a_program_and_its_label_fits_a_process_name() -> None:
    assert is_file_program("./mine.py:Forward")
    assert is_file_program("mine.py")
    assert is_file_program("agents/mine")
    assert not is_file_program("waypoint")
    assert program_label("./my-agent.py:Forward") == "my-agent"
    assert program_label("waypoint") == "waypoint"


@pytest.mark.usefixtures("agent_file")
def test_a_class_gets_the_files_own_options_and_make_is_the_default() -> None:
    (fwd,) = _made("./mine.py:Forward", "--power", "0.12")
    assert fwd.power == 0.12  # type: ignore[attr-defined]
    assert [a.spec().name for a in _made("./mine.py")] == ["fwd", "still"]  # type: ignore[attr-defined]
    assert [a.spec().name for a in _made("mine.py:Still")] == ["still"]  # type: ignore[attr-defined]
    assert [a.spec().name for a in _made("mine.py:ready")] == ["still"]  # type: ignore[attr-defined]
    assert find_program("./mine.py").doc == "Goes forward."


@pytest.mark.usefixtures("agent_file")
@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("./gone.py:Forward", "./gone.py: no such file"),
        ("./mine.py:Froward", "./mine.py has no 'Froward' (it defines: BadSpec, Forward, Still, add_arguments, make"),
        ("./mine.py:number", "./mine.py:number is an int, not an agent class"),
    ],
)
def test_a_file_or_name_that_is_not_there_is_refused_saying_what(text: str, said: str) -> None:
    with pytest.raises(ProgramError) as e:
        find_program(text)
    assert said in str(e.value)


@pytest.mark.usefixtures("agent_file")
@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("./mine.py:text", "text made a str, not an agent"),
        (
            "./mine.py:BadSpec",
            f'BadSpec(...).spec() failed: line {BAD_LINE}, in spec: return RobotSpec("bad", width_m=-1.0)',
        ),
        ("./mine.py:BadSpec", "SpecError: width_m: must be > 0, got -1.0"),
    ],
)
def test_what_is_made_must_be_agents_with_a_spec_in_range(text: str, said: str) -> None:
    with pytest.raises(ProgramError) as e:
        _made(text)
    assert said in str(e.value)


def test_a_file_that_does_not_import_shows_the_users_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "typo.py").write_text("import math\n\ndef f(:\n    pass\n")
    (tmp_path / "fails.py").write_text("import math\n\nx = math.sqroot(2)\n")
    with pytest.raises(ProgramError) as e:
        find_program("typo.py:f")
    assert "typo.py, line 3: invalid syntax" in str(e.value)
    assert "def f(:" in str(e.value)
    with pytest.raises(ProgramError) as e:
        find_program("fails.py:f")
    assert "fails.py could not be imported: line 3, in <module>: x = math.sqroot(2)" in str(e.value)
    assert "AttributeError: module 'math' has no attribute 'sqroot'" in str(e.value)


def test_a_misspelled_program_that_ships_is_refused_with_the_nearest_name() -> None:
    with pytest.raises(ProgramError, match=r"no agent program 'wayponit' \(did you mean 'waypoint'\?\); programs: "):
        find_program("wayponit")


@pytest.mark.usefixtures("agent_file")
def test_resim_swaps_in_an_agent_from_the_users_file() -> None:
    from iw_zenoh.record.resim import _make_agent

    rid, agent = _make_agent("2=./mine.py:Forward --power 0.05")
    assert rid == 2
    assert agent.power == 0.05
