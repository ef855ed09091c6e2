"""iwz calibrate refuses a malformed log (the CSV ``iwz bridge serial --log`` writes) with the file,
the line, what is wrong and how to fix it; it never fits one, and never ends in a traceback."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from iw_zenoh.bridges.serial.node import CSV_HEADER

from iw_zenoh.record.calibrate import main as calibrate
from tests.support.serial_logs import bridge_log as _bridge_log

Edit = Callable[[list[str]], list[str]]  # the log's lines (header first) to the malformed ones


def _field(line: int, col: int, text: str) -> Edit:
    def edit(lines: list[str]) -> list[str]:
        fields = lines[line - 1].split(",")
        fields[col] = text
        return [*lines[: line - 1], ",".join(fields), *lines[line:]]

    return edit


CASES: dict[str, tuple[Edit, int | None, str]] = {  # edit, the line named (None: the file), what is said
    "a truncated last row": (
        lambda ls: [*ls[:-1], ls[-1][:12]],
        161,
        "2 fields where the header has 9: a truncated row",
    ),
    "a truncated row inside": (lambda ls: [*ls[:40], ls[40][:20], *ls[41:]], 41, "fields where the header has 9"),
    "two rows run together": (lambda ls: [*ls[:50], ls[50] + "," + ls[51], *ls[52:]], 51, "18 fields"),
    "a word for ticks": (_field(30, 1, "abc"), 30, "column left_ticks holds 'abc', not a number"),
    "an empty field": (_field(30, 3, ""), 30, "column left_cmd holds '', not a number"),
    "a NaN time": (_field(70, 0, "nan"), 70, "column t holds 'nan'"),
    "an infinite count": (_field(80, 2, "inf"), 80, "column right_ticks holds 'inf'"),
    "a -inf command": (_field(90, 4, "-inf"), 90, "column right_cmd holds '-inf'"),
    "a huge count": (_field(100, 1, "1e300"), 100, "column left_ticks holds 1e+300, beyond"),
    "a huge time": (_field(100, 0, "1e20"), 100, "column t holds 1e+20, beyond +-1e+10 seconds"),
    "a huge command": (_field(100, 3, "15"), 100, "column left_cmd holds 15, beyond +-1 motor power"),
    "times that go back": (_field(60, 0, "1.0"), 60, "t = 1 does not come after t = 12.85 (line 59)"),
    "two runs in one file": (lambda ls: ls + ls, 162, "the header again: the file holds more than one run"),
    "an empty file": (lambda ls: [], None, "empty: give the CSV log of a run"),
    "blank lines only": (lambda ls: ["", "  ", ""], None, "empty"),
    "a header only": (lambda ls: ls[:1], None, "a header and no rows"),
    "a wrong header": (lambda ls: ["time,l,r,lc,rc", *ls[1:]], 1, "the header is time,l,r,lc,rc; it must name t,speed"),
    "no header": (lambda ls: ls[1:], 1, "no header: the first line holds numbers"),
    "a column named twice": (lambda ls: ["t,speed,speed", "0,0,0"], 1, "the header names speed twice"),
    "too few rows to fit": (lambda ls: ["t,speed", "0,0", "0.1,0.2", "0.2,0.3"], None, "at least 10 samples"),
    "no step in it": (
        lambda ls: [ls[0], *(",".join([row.split(",")[0], "0", "0", "0", "0", "0", "0", "25", "0"]) for row in ls[1:])],
        None,
        "never commands both wheels forward",
    ),
}


@pytest.fixture(scope="module")
def _good_lines(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, ...]:
    """The bridge's log of a seeded run, made once for the module (160 board steps each time, over a
    second per case under load, gave the same lines)."""
    folder = tmp_path_factory.mktemp("good")
    spec = folder / "chair.toml"
    spec.write_text("[chair]\nacceleration_curve = 0.9\nmax_speed_mps = 0.49\n")
    log = folder / "good.csv"
    _bridge_log(log, spec)
    lines = log.read_text().splitlines()
    assert lines[0] == CSV_HEADER.strip()
    assert calibrate([str(log)]) == 0  # the log the cases spoil is a good one
    return tuple(lines)


@pytest.fixture
def good_log(_good_lines: tuple[str, ...]) -> list[str]:
    return list(_good_lines)  # each case spoils its own copy


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_a_malformed_log_is_refused_naming_the_file_the_line_and_what(
    case: str, good_log: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    edit, line, what = CASES[case]
    bad = tmp_path / "bad.csv"
    lines = edit(good_log)
    bad.write_text("\n".join(lines) + ("\n" if lines else ""))
    capsys.readouterr()
    assert calibrate([str(bad)]) == 2
    out, err = capsys.readouterr()
    where = f"{bad} line {line}: " if line is not None else f"{bad}: "
    assert err.startswith(f"iwz calibrate: error: {where}"), err
    assert what in err
    assert "MaxSpeed" not in out  # nothing fitted


@pytest.mark.parametrize(
    ("content", "what"),
    [(b"\xff\xfe\x00t,speed\n\x80\x81", "not text (UTF-8)"), (b"t,speed\n0,\x000\n", "line 2: column speed holds")],
    ids=["binary", "a NUL byte"],
)
def test_a_file_that_is_not_csv_text_is_refused(
    content: bytes, what: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_bytes(content)
    assert calibrate([str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"iwz calibrate: error: {bad}"), err
    assert what in err


@pytest.mark.parametrize("where", ["missing.csv", "."], ids=["missing", "a directory"])
def test_a_path_that_cannot_be_read_is_refused(where: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / where
    assert calibrate([str(path)]) == 2
    assert "cannot read it" in capsys.readouterr().err


@pytest.mark.parametrize("flag", [["--ticks-per-m", "nan"], ["--ticks-per-m", "0"], ["--period-ms", "-100"]])
def test_nonsense_options_are_refused_by_the_parser(
    flag: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as e:
        calibrate([str(tmp_path / "x.csv"), *flag])
    assert e.value.code == 2
    assert "must be a positive number" in capsys.readouterr().err


def test_the_command_exits_non_zero_without_a_traceback(tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text(CSV_HEADER + "10.0,0,0,0.15,0.15,0,0,25.0,0\n10.05,nan,3,0.15,0.15,0,0,25.0,0\n")
    r = subprocess.run(
        [sys.executable, "-m", "iw_zenoh.cli", "calibrate", str(bad)], capture_output=True, text=True, timeout=60
    )
    assert r.returncode == 2
    assert "Traceback" not in r.stderr + r.stdout
    assert (
        r.stderr.strip()
        == f"iwz calibrate: error: {bad} line 3: column left_ticks holds 'nan': a number is needed (finite)"
    )
