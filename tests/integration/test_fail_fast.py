"""An agent that cannot start ends ``iwz run`` at once with exit 3, its name and its error on
stderr: a misspelled program, a user's file with a syntax error (real launcher, real processes)."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest

from tests.integration.harness import MAPS, iwz_run_argv, stop_run

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(300)]

SCENARIO = """
[world]
map = "{map}"
mode = "lockstep"
duration_s = 600

[[agents]]
program = "waypoint"
args = ["--waypoints", "8,3", "--start", "1.5,3,0", "--id", "1"]

[[agents]]
program = "{program}"
args = ["--id", "2"]

[[criteria.reach]]
robot = 1
x_m = 8
y_m = 3
"""


def _run(tmp: Path, program: str, args: str = '["--id", "2"]') -> tuple[int, str, str, float]:
    scenario = tmp / "broken.toml"
    text = SCENARIO.format(map=MAPS / "open-room.xml", program=program)
    scenario.write_text(text.replace('args = ["--id", "2"]', f"args = {args}"))
    argv = iwz_run_argv(scenario, tmp / "logs", "ff")
    t0 = time.monotonic()
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = p.communicate(timeout=200)
    except subprocess.TimeoutExpired:
        out, err = stop_run(p)
        pytest.fail(f"still running after 200 s (the world waits 600 s), stopped:\n{out}{err}")
    return p.returncode, out, err, time.monotonic() - t0


def test_a_misspelled_agent_ends_the_run_at_once_with_exit_3_its_name_and_error(tmp_path: Path) -> None:
    code, out, err, took = _run(tmp_path, "wayponit")
    assert code == 3, out + err
    assert "iwz run: agent-2-wayponit could not start (exit 2): " in err
    assert "no agent program 'wayponit' (did you mean 'waypoint'?)" in err
    assert "never seen" not in out + err
    assert "restarting" not in out
    assert took < 120, f"took {took:.0f} s"  # seconds, even on a loaded machine; not the wall-clock limit


def test_a_users_file_with_a_syntax_error_ends_the_run_with_its_line(tmp_path: Path) -> None:
    (tmp_path / "mine.py").write_text('"""Mine."""\n\nclass Mine:\n    def spec(self)\n        pass\n')
    code, out, err, took = _run(tmp_path, "./mine.py:Mine")
    assert code == 3, out + err
    assert "iwz run: agent-2-mine could not start (exit 2): iwz agent: mine.py, line 4: " in err
    assert "def spec(self)" in err
    assert "never seen" not in out + err
    assert took < 120, f"took {took:.0f} s"


def test_an_agent_whose_robot_is_refused_ends_the_run_with_the_worlds_reason(tmp_path: Path) -> None:
    code, out, err, _ = _run(tmp_path, "waypoint", '["--id", "2", "--waypoints", "1,1", "--start", "50,50,0"]')
    assert code == 3, out + err
    assert "iwz run: agent-2-waypoint could not start (exit 3): " in err
    assert "start (50, 50) is outside the lab (12 x 6)" in err
