"""``iwz view RUN.mcap`` in Debian's Chromium on a recording made now: a lock-step run of two
chairs, one carrying a laser scanner, recorded by ``iwz run`` (router, world, collision, sensors,
recorder and each agent its own process), then replayed with its timeline: every robot shown,
seek and step, the scan drawn where its beams hit, the scanner's nearest range in the panel."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Browser, Page

from iw_zenoh.messages import SensorBatch, SensorReading, WorldInfo, WorldState
from iw_zenoh.record.reader import open_recording
from tests.integration.browser import hooked, record_run, replay_page

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(300)]

SIM = "scanview"
# the scanner's chair drives east along y = 5 towards the wall's face at x = 15; its middle beam
# (of 9 over 180 degrees) looks straight at it; the other chair drives along y = 2, in its first beam
AGENTS = """[[agents]]
program = "waypoint"
args = ["--waypoints", "12,5", "--start", "5,5,0", "--robot-name", "scanner", "--id", "1"]
name = "scanner-agent"
spec = { lasers = [{ id = 0, x_m = 0.5, fov_deg = 180, beams = 9, range_m = 12 }], noise = false }

[[agents]]
program = "waypoint"
args = ["--waypoints", "12,2", "--start", "5,2,0", "--robot-name", "plain", "--id", "2"]
name = "plain-agent"
"""
SCAN_POINT = [255, 64, 129, 255]  # view2d.js SCAN_POINT, opaque
WAIT_MS = 30_000


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A lock-step run of the scenario, recorded by ``iwz run``."""
    return record_run(tmp_path_factory.mktemp("scanrun"), SIM, name="scan-replay", agents=AGENTS)


@pytest.fixture(scope="module")
def replay(recorded: Path) -> Iterator[str]:
    """``iwz view`` replaying it."""
    with replay_page(recorded, SIM, "view-replay") as url:
        yield url


def _contents(rec: Path) -> tuple[WorldInfo, list[WorldState], dict[int, SensorReading]]:
    """The last description, every state, and the scanner chair's readings by tick."""
    info: WorldInfo | None = None
    states: list[WorldState] = []
    scans: dict[int, SensorReading] = {}
    with open_recording(rec) as r:
        for one in r.records():
            m = one.message
            if isinstance(m, WorldInfo):
                info = m
            elif isinstance(m, WorldState):
                states.append(m)
            elif isinstance(m, SensorBatch):
                scans.update((s.tick, s) for s in m.readings if s.robot_id == 1)
    assert info is not None
    return info, states, scans


def _paused_at_seek(page: Page, states: list[WorldState]) -> WorldState:
    """Pauses, clicks the timeline's track at 60 %; the state the page shows, checked against the file."""
    page.click("#btn-pause")
    page.wait_for_function("window.iwz.world.timeline && !window.iwz.world.timeline.playing", timeout=WAIT_MS)
    track = page.locator("#tl-range").bounding_box()
    assert track is not None
    page.mouse.click(track["x"] + track["width"] * 0.6, track["y"] + track["height"] / 2)
    seek = page.wait_for_function(
        "window.iwz.sent.filter((c) => c.cmd === 'seek').map((c) => c.at_ns).pop()", timeout=WAIT_MS
    ).json_value()
    want = next(s for s in states if s.sim_time_ns >= seek)
    assert states[0].tick < want.tick < states[-1].tick  # somewhere inside the run
    page.wait_for_function(f"window.iwz.world.tick === {want.tick}", timeout=WAIT_MS)
    return want


def test_a_run_recorded_now_replays_with_every_robot_its_agents_seek_and_step(
    recorded: Path, replay: str, browser: Browser
) -> None:
    info, states, _ = _contents(recorded)
    assert isinstance(info.agents, list)  # the world's description names each robot's agent
    assert dict(zip([r.name for r in info.robots], info.agents, strict=True)) == {
        "scanner": "scanner-agent",
        "plain": "plain-agent",
    }
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.goto(hooked(replay))
    page.wait_for_function("window.iwz && window.iwz.world.ids.length === 2", timeout=WAIT_MS * 2)
    shown = page.evaluate("[...window.iwz.world.robots.values()].map((r) => [r.id, r.name, r.agent])")
    assert sorted(map(tuple, shown)) == [(1, "scanner", "scanner-agent"), (2, "plain", "plain-agent")]

    want = _paused_at_seek(page, states)
    robots = {r["id"]: r for r in page.evaluate("window.iwz.robots()")}
    assert set(robots) == set(want.ids)
    for i, rid in enumerate(want.ids):
        assert (robots[rid]["x"], robots[rid]["y"]) == pytest.approx((want.x[i], want.y[i]), abs=1e-3)
        assert robots[rid]["heading"] == pytest.approx(want.heading[i], abs=1e-3)
    page.click("#btn-step")  # the next recorded tick, and no further
    following = states[states.index(want) + 1]
    page.wait_for_function(f"window.iwz.world.tick === {following.tick}", timeout=WAIT_MS)
    assert not page.evaluate("window.iwz.world.timeline.playing")
    page.close()


def test_the_timeline_ends_at_the_last_recorded_state_and_seeking_to_its_end_shows_it(
    recorded: Path, replay: str, browser: Browser
) -> None:
    _, states, _ = _contents(recorded)
    last = states[-1]
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.goto(hooked(replay))
    page.wait_for_function("window.iwz && window.iwz.world.timeline", timeout=WAIT_MS * 2)
    assert page.evaluate("window.iwz.world.timeline.end_ns") == last.sim_time_ns
    assert page.inner_text("#tl-end") == f"{last.sim_time_ns / 1e9:.1f} s"
    page.click("#btn-pause")
    page.wait_for_function("!window.iwz.world.timeline.playing", timeout=WAIT_MS)
    page.focus("#tl-range")
    page.keyboard.press("End")  # the track's end
    page.wait_for_function(f"window.iwz.world.tick === {last.tick}", timeout=WAIT_MS)
    assert page.evaluate("window.iwz.sent.filter((c) => c.cmd === 'seek').pop().at_ns") == last.sim_time_ns
    robots = {r["id"]: r for r in page.evaluate("window.iwz.robots()")}
    assert set(robots) == set(last.ids)
    for i, rid in enumerate(last.ids):
        assert (robots[rid]["x"], robots[rid]["y"]) == pytest.approx((last.x[i], last.y[i]), abs=1e-3)
    page.wait_for_function(f"window.iwz.world.timeline.position_ns === {last.sim_time_ns}", timeout=WAIT_MS)
    assert page.inner_text("#tl-pos") == page.inner_text("#tl-end")
    page.close()


def _wall_hit(page: Page) -> list[float]:
    """The drawn scan hit on the wall's face (x = 15) nearest the chair's line (y = 5): the middle
    beam's."""
    points = [p for p in page.evaluate("window.iwz.scanPoints()") if p[0] > 14.0]
    assert points, "no scan hit drawn on the wall"
    return min(points, key=lambda p: abs(p[1] - 5.0))


def test_the_replayed_scan_is_drawn_where_its_beams_hit_and_the_panel_gives_its_nearest_range(
    recorded: Path, replay: str, browser: Browser
) -> None:
    _, states, scans = _contents(recorded)
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.goto(hooked(replay))
    page.wait_for_function("window.iwz && window.iwz.world.ids.length === 2", timeout=WAIT_MS * 2)
    for opt in ("#opt-trails", "#opt-cones", "#opt-labels"):  # nothing drawn over the scan
        page.uncheck(opt)
    want = _paused_at_seek(page, states)
    page.wait_for_function("window.iwz.world.scans.has(1) && window.iwz.scanPoints().length > 0", timeout=WAIT_MS)
    shown = page.evaluate("window.iwz.world.scans.get(1)")
    recorded_near = [s for t, s in scans.items() if want.tick - 2 <= t <= want.tick]  # the last scan sent
    assert any(
        shown == [[None if v is None else round(v, 2) for v in s.lasers[0].ranges]]  # type: ignore[index]
        for s in recorded_near
    ), (shown, want.tick)
    assert len(page.evaluate("window.iwz.scanPoints()")) == sum(v is not None for v in shown[0])
    hit = _wall_hit(page)
    assert hit == pytest.approx([15.0, 5.0], abs=0.1)  # the wall's face, straight ahead of the chair
    page.wait_for_function(f"window.iwz.pixel({hit[0]}, {hit[1]}).join() === '{','.join(map(str, SCAN_POINT))}'")

    page.uncheck("#opt-scans")  # off: only the selected robot's scan, and none is selected
    page.wait_for_function("window.iwz.scanPoints().length === 0", timeout=WAIT_MS)
    assert page.evaluate(f"window.iwz.pixel({hit[0]}, {hit[1]})") != SCAN_POINT
    box = page.locator("#view2d").bounding_box()
    assert box is not None
    i = want.ids.index(1)
    sx, sy = page.evaluate(f"window.iwz.toScreen({want.x[i]}, {want.y[i]})")
    page.mouse.click(box["x"] + sx, box["y"] + sy)  # selects the scanner's chair: its scan is back
    page.wait_for_function("window.iwz.scanPoints().length > 0", timeout=WAIT_MS)
    page.wait_for_selector("#panel:not([hidden])", timeout=WAIT_MS)
    page.wait_for_function("document.querySelector('#panel-body').innerText.includes('laser 0')", timeout=WAIT_MS)
    tick = page.evaluate("window.iwz.world.reading.reading.tick")
    nearest = min(v for v in scans[tick].lasers[0].ranges if v is not None)  # type: ignore[union-attr]
    body = page.inner_text("#panel-body")
    assert f"nearest {nearest:.2f} m" in body, body
    assert "scanner-agent" in body
    page.close()
