"""``iwz view`` sends a page only the laser scans it draws, in Debian's Chromium: two chairs, each
carrying a scanner, recorded now by ``iwz run`` and replayed step by step; what arrives on the
page's WebSocket is counted while its scans toggle and its selection change."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Browser, Page, WebSocket

from iw_zenoh.messages import WorldState
from iw_zenoh.record.reader import open_recording
from tests.integration.browser import hooked, record_run, replay_page

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(300)]

SIM = "scansent"
LASER = "spec = { lasers = [{ id = 0, x_m = 0.5, fov_deg = 90, beams = 5, range_m = 12 }], noise = false }"
# both chairs drive east towards the wall: every tick each scan moves by a few centimetres
AGENTS = f"""[[agents]]
program = "waypoint"
args = ["--waypoints", "12,3", "--start", "5,3,0", "--robot-name", "low", "--id", "1"]
name = "low-agent"
{LASER}

[[agents]]
program = "waypoint"
args = ["--waypoints", "12,7", "--start", "5,7,0", "--robot-name", "high", "--id", "2"]
name = "high-agent"
{LASER}
"""
WAIT_MS = 30_000
STEPS = 4  # steps played in each phase


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A lock-step run of the scenario, recorded by ``iwz run``."""
    return record_run(tmp_path_factory.mktemp("scansent"), SIM, name="scans-sent", agents=AGENTS)


@pytest.fixture(scope="module")
def replay(recorded: Path) -> Iterator[str]:
    """``iwz view`` replaying it."""
    with replay_page(recorded, SIM, "view-scans") as url:
        yield url


def _listen(page: Page, got: list[dict[str, Any]]) -> None:
    """Every text message the page's WebSocket receives, decoded, into ``got``."""

    def on_socket(ws: WebSocket) -> None:
        ws.on("framereceived", lambda data: got.append(json.loads(data)) if isinstance(data, str) else None)

    page.on("websocket", on_socket)


def _step(page: Page, ticks: list[int], count: int) -> int:
    """Steps the paused replay ``count`` recorded ticks on; the tick shown then."""
    tick = int(page.evaluate("window.iwz.world.tick"))
    for _ in range(count):
        tick = ticks[ticks.index(tick) + 1]
        page.click("#btn-step")
        page.wait_for_function(f"window.iwz.world.tick === {tick}", timeout=WAIT_MS)
    return tick


def _scans_from(got: list[dict[str, Any]], mark: int, tick: int) -> list[set[str]]:
    """The robots of each ``scans`` message received since ``got[mark]`` of ``tick`` or later (a
    replay's ticks go back when it seeks: the run played through before the page joined)."""
    return [set(m["scans"]) for m in got[mark:] if m["type"] == "scans" and m["tick"] >= tick]


def _said(page: Page, scans: str) -> None:
    page.wait_for_function(f"window.iwz.sent.some((c) => c.cmd === 'scans' && c.scans === '{scans}')", timeout=WAIT_MS)


def test_the_server_sends_a_page_only_the_scans_it_draws(recorded: Path, replay: str, browser: Browser) -> None:
    with open_recording(recorded) as r:
        states = [one.message for one in r.records(("state",)) if isinstance(one.message, WorldState)]
    ticks = [s.tick for s in states]
    got: list[dict[str, Any]] = []
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    _listen(page, got)
    page.goto(hooked(replay))
    page.wait_for_function("window.iwz && window.iwz.world.ids.length === 2", timeout=WAIT_MS * 2)
    for opt in ("#opt-trails", "#opt-cones", "#opt-labels"):
        page.uncheck(opt)
    page.click("#btn-pause")
    page.wait_for_function("window.iwz.world.timeline && !window.iwz.world.timeline.playing", timeout=WAIT_MS)
    page.focus("#tl-range")
    page.keyboard.press("Home")  # back to the first state, paused there
    page.wait_for_function(f"window.iwz.world.tick === {ticks[0]}", timeout=WAIT_MS)

    mark = len(got)
    start = _step(page, ticks, 1)  # the toggle on (two robots): every robot's scans
    _step(page, ticks, STEPS)
    every = _scans_from(got, mark, start)
    assert every
    assert set().union(*every) == {"1", "2"}, every

    page.uncheck("#opt-scans")  # off, nothing selected: no robot's scans
    _said(page, "none")
    mark = len(got)
    off = _step(page, ticks, 1)
    _step(page, ticks, STEPS)
    assert _scans_from(got, mark, off) == []
    assert sum(m["type"] == "frame" and m["tick"] >= off for m in got[mark:]) >= STEPS  # (the world went on)
    assert page.evaluate("window.iwz.scanPoints().length") == 0

    box = page.locator("#view2d").bounding_box()
    assert box is not None
    now = {r["id"]: r for r in page.evaluate("window.iwz.robots()")}
    sx, sy = page.evaluate(f"window.iwz.toScreen({now[2]['x']}, {now[2]['y']})")
    mark = len(got)
    page.mouse.click(box["x"] + sx, box["y"] + sy)  # selects chair 2: its scans only
    _said(page, "selected")
    assert page.evaluate("window.iwz.sent.filter((c) => c.cmd === 'scans').pop().robot_id") == 2
    one = int(page.evaluate("window.iwz.world.tick"))
    _step(page, ticks, STEPS)
    only = _scans_from(got, mark, one)
    assert only  # its last scan at once, then each change
    assert all(robots == {"2"} for robots in only), only
    page.wait_for_function("window.iwz.scanPoints().length > 0", timeout=WAIT_MS)
    assert page.evaluate("[...window.iwz.world.scans.keys()]") == [2]

    mark, tick = len(got), int(page.evaluate("window.iwz.world.tick"))
    page.check("#opt-scans")  # on again: every robot's last scans at once
    _said(page, "all")
    page.wait_for_function("window.iwz.world.scans.size === 2", timeout=WAIT_MS)
    assert {"1", "2"} in _scans_from(got, mark, tick)
    page.close()
