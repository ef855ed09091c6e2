"""Debian's Chromium, driven by Playwright, for the viewer's browser tests (never a browser
download: the README's test command installs the chromium package)."""

from __future__ import annotations

import re
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from playwright.sync_api import Browser, sync_playwright

from benchmarks.chromium import CHROMIUM, INSTALL, hooked, launch
from tests.integration.harness import Net, Proc, iwz_run_argv, stop_run

__all__ = ["RUN_S", "WALL_LAB", "chromium", "hooked", "record_run", "replay_page", "viewer_url"]

RUN_S = 180  # a lock-step run of a few seconds, recorded, on a loaded machine
WALL_LAB = """<Lab Name="scan" Width="20" Height="10">
  <Wall Height="1.0"><Corner X="15" Y="1"/><Corner X="16" Y="1"/><Corner X="16" Y="9"/><Corner X="15" Y="9"/></Wall>
</Lab>"""  # a wall across the lab whose west face is at x = 15, for chairs to drive and scan towards
RUN_HEAD = """name = "{name}"

[world]
map = "lab.xml"
mode = "lockstep"
seed = 1
duration_s = 3

[roles]
radio = false

"""  # a reproducible three-second run in WALL_LAB, agents to follow


@contextmanager
def chromium() -> Iterator[Browser]:
    """Debian's Chromium under Playwright; fails (never skips) when it is not installed."""
    if not CHROMIUM.exists():
        pytest.fail(
            f"{CHROMIUM} is missing: the viewer's browser tests need Debian's chromium. Install it with "
            f"`{INSTALL}` (the README's test command does)"
        )
    with sync_playwright() as p:
        browser = launch(p)
        try:
            yield browser
        finally:
            browser.close()


def viewer_url(proc: Proc, timeout_s: float = 60.0) -> str:
    """The page's address, as ``iwz view`` prints it once it serves."""
    deadline = time.monotonic() + timeout_s
    while True:
        m = re.search(r"iwz view: (http://\S+/)", proc.output())
        if m:
            return m.group(1)
        assert proc.popen.poll() is None, f"iwz view died:\n{proc.output()}"
        assert time.monotonic() < deadline, f"iwz view did not serve within {timeout_s} s:\n{proc.output()}"
        time.sleep(0.05)  # polling its log: there is no event to wait on


def record_run(tmp: Path, sim: str, *, name: str, agents: str) -> Path:
    """Runs a lock-step scenario of three seconds in WALL_LAB with ``agents`` (its ``[[agents]]``
    tables) by ``iwz run``, recorded; the recording. Fails with the run's output if it fails or is
    still running after RUN_S."""
    (tmp / "lab.xml").write_text(WALL_LAB)
    (tmp / "scenario.toml").write_text(RUN_HEAD.format(name=name) + agents)
    rec = tmp / "run.mcap"
    argv = iwz_run_argv(tmp / "scenario.toml", tmp, sim, record=rec)
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = p.communicate(timeout=RUN_S)
    except subprocess.TimeoutExpired:
        out, err = stop_run(p)
        pytest.fail(f"iwz run still running after {RUN_S} s, stopped:\n{out}{err}")
    assert p.returncode == 0, out + err
    assert rec.exists(), out + err
    return rec


@contextmanager
def replay_page(recorded: Path, sim: str, name: str) -> Iterator[str]:
    """``iwz view`` replaying ``recorded`` (no router: a replay needs none); the page's address.
    The viewer is stopped on leaving."""
    net = Net(recorded.parent, sim=sim)
    try:
        yield viewer_url(net.spawn("view", str(recorded), "--port", "0", name=name, connect=False))
    finally:
        net.close()
