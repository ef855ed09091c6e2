"""docs/first-agent.md, run as written: its agent file and its scenario, extracted from the page,
drive a chair of the user's own to its goal through ``iwz run``."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.integration.harness import MAPS, ROOT, iwz_run_argv, stop_run

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(400)]

DOC = ROOT / "docs" / "first-agent.md"


def _files(text: str) -> dict[str, str]:
    """Each code block preceded by ``<!-- file: NAME -->``: its name and its text."""
    return dict(re.findall(r"<!-- file: (\S+) -->\n```\w*\n(.*?)```", text, flags=re.S))


def _commands(text: str) -> list[str]:
    """Each command of a code block preceded by ``<!-- run -->``."""
    blocks = re.findall(r"<!-- run -->\n```\w*\n(.*?)```", text, flags=re.S)
    return [line.strip() for b in blocks for line in b.splitlines() if line.strip()]


def test_the_first_agent_page_drives_a_chair_to_its_goal_as_written(tmp_path: Path) -> None:
    text = DOC.read_text()
    files = _files(text)
    assert set(files) == {"go_to.py", "my_run.toml"}
    assert len(files["go_to.py"].splitlines()) <= 30  # about 20 lines of agent
    for name, body in files.items():
        (tmp_path / name).write_text(body)
    (tmp_path / "maps").symlink_to(MAPS)  # the page works in the folder iw-zenoh was cloned to
    assert _commands(text) == ["iwz run my_run.toml"]
    argv = iwz_run_argv(Path("my_run.toml"), tmp_path / "logs", "first")
    p = subprocess.Popen(argv, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = p.communicate(timeout=300)
    except subprocess.TimeoutExpired:
        out, err = stop_run(p)
        pytest.fail(f"still running after 300 s, stopped:\n{out}{err}")
    assert p.returncode == 0, out + err
    assert "PASS robot 1 within 0.5 m of (10.5, 3)" in out
    assert "every goal reached" in out


def test_the_first_agent_runs_by_hand_and_says_its_options(tmp_path: Path) -> None:
    (tmp_path / "go_to.py").write_text(_files(DOC.read_text())["go_to.py"])
    argv = [sys.executable, "-m", "iw_zenoh.cli", "agent", "./go_to.py:GoTo", "--help"]
    r = subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, timeout=60, check=False)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "Drives a chair straight to --goal" in r.stdout
    assert "--goal GOAL" in r.stdout


def test_the_first_agent_imports_everything_it_uses_from_one_module() -> None:
    code = _files(DOC.read_text())["go_to.py"]
    ours = [line for line in code.splitlines() if re.match(r"\s*(from|import) iw_zenoh\b", line)]
    assert ours == ["from iw_zenoh.agent import Command, SensorNoise, Spec, point_arg"]
    assert "/ 1000" not in code  # no wheel powers worked out by hand: a velocity, through the chair's model
