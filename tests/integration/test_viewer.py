"""``iwz view`` in Debian's Chromium: a live run seen and steered from the page (router, world,
collision, sensors, radio, three chairs and the viewer, each its own process), and a recording
replayed with its timeline."""

from __future__ import annotations

import math
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Browser, Page

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.messages import SensorBatch, Tick, WorldInfo, WorldState
from iw_zenoh.record.reader import open_recording
from tests.integration.browser import hooked, viewer_url
from tests.integration.harness import ROOT, Net, subscribe, wait_event, wait_msg

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

LAB = '<Lab Name="open" Width="40" Height="12"/>'
CHAIRS = {  # name: start, waypoints (back and forth along the lab: they keep driving)
    "north": ("5,9,0", "35,9;5,9;35,9;5,9"),
    "middle": ("5,6,0", "35,6;5,6;35,6;5,6"),
    "south": ("5,3,0", "35,3;5,3;35,3;5,3"),
}
SAMPLE = ROOT / "recordings" / "demo-sample.mcap"
WAIT_MS = 30_000


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Net, ZenohBus, str]]:
    """A live run with three chairs and ``iwz view --port 0`` on it."""
    net = Net(tmp_path_factory.mktemp("viewer"), sim="view")
    net.start_router()
    try:
        (net.tmp / "lab.xml").write_text(LAB)
        bus = net.client()
        net.spawn("world", str(net.tmp / "lab.xml"))
        for role in ("collision", "sensors", "radio"):
            net.spawn(role)
        for name, (start, waypoints) in CHAIRS.items():
            net.spawn(
                "agent", "waypoint", "--waypoints", waypoints, "--start", start, "--robot-name", name, "--name", name
            )
        url = viewer_url(net.spawn("view", "--port", "0", "--foxglove-port", "0"))
        yield net, bus, url
    finally:
        net.close()


def _open(browser: Browser, url: str, robots: int) -> Page:
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.goto(hooked(url))
    page.wait_for_function(f"window.iwz && window.iwz.world.ids.length === {robots}", timeout=WAIT_MS * 2)
    return page


def _robots(page: Page) -> dict[int, dict[str, Any]]:
    return {r["id"]: r for r in page.evaluate("window.iwz.robots()")}


def _tick(page: Page) -> int:
    return int(page.evaluate("window.iwz.world.tick"))


def _ticks_while_paused(bus: ZenohBus, sim: str, count: int) -> list[int]:
    """The tick numbers of the next ``count`` clock messages (the world sends one each period)."""
    box = subscribe(bus, keys.tick(sim))
    return [wait_msg(box, Tick, timeout_s=20).tick for _ in range(count)]


def _pause(page: Page, bus: ZenohBus, sim: str) -> int:
    """Pauses from the page; the tick it stopped at, once the page shows it."""
    page.click("#btn-pause")
    ticks = subscribe(bus, keys.tick(sim))
    stopped = wait_msg(ticks, Tick, lambda t: not t.running, timeout_s=20).tick
    page.wait_for_function(f"window.iwz.world.tick === {stopped}", timeout=WAIT_MS)
    return stopped


def test_the_live_page_shows_every_robot_and_their_poses_change(
    live: tuple[Net, ZenohBus, str], browser: Browser
) -> None:
    net, bus, url = live
    page = _open(browser, url, len(CHAIRS))
    names = page.evaluate("[...window.iwz.world.robots.values()].map((r) => r.name).sort()")
    assert names == sorted(CHAIRS)
    state = wait_msg(subscribe(bus, keys.state(net.sim)), WorldState, lambda s: len(s.ids) == 3)
    assert set(_robots(page)) == set(state.ids)
    before = _robots(page)
    page.wait_for_function(
        "(b) => window.iwz.robots().every((r) => Math.hypot(r.x - b[r.id].x, r.y - b[r.id].y) > 0.2)",
        arg={str(k): v for k, v in before.items()},
        timeout=WAIT_MS,
    )
    assert "running" in page.inner_text("#hud-mode")
    page.close()


def test_pause_stops_sim_time_step_advances_one_tick_and_start_resumes(
    live: tuple[Net, ZenohBus, str], browser: Browser
) -> None:
    net, bus, url = live
    page = _open(browser, url, len(CHAIRS))
    stopped = _pause(page, bus, net.sim)
    assert _ticks_while_paused(bus, net.sim, 3) == [stopped] * 3
    assert _tick(page) == stopped
    assert "paused" in page.inner_text("#hud-mode")

    page.click("#btn-step")
    page.wait_for_function(f"window.iwz.world.tick === {stopped + 1}", timeout=WAIT_MS)
    assert _ticks_while_paused(bus, net.sim, 3) == [stopped + 1] * 3
    assert _tick(page) == stopped + 1

    page.click("#btn-start")
    page.wait_for_function(f"window.iwz.world.tick > {stopped + 5}", timeout=WAIT_MS)
    page.close()


def _drag_box(page: Page, x0: float, y0: float, x1: float, y1: float) -> None:
    """Draws an obstacle on the map with the mouse, from (x0, y0) to (x1, y1) in metres."""
    page.click("#btn-obstacle")
    box = page.locator("#view2d").bounding_box()
    assert box is not None
    a = page.evaluate(f"window.iwz.toScreen({x0}, {y0})")
    b = page.evaluate(f"window.iwz.toScreen({x1}, {y1})")
    page.mouse.move(box["x"] + a[0], box["y"] + a[1])
    page.mouse.down()
    page.mouse.move(box["x"] + (a[0] + b[0]) / 2, box["y"] + (a[1] + b[1]) / 2)
    page.mouse.move(box["x"] + b[0], box["y"] + b[1])
    page.mouse.up()


def _front(batch: SensorBatch, robot_id: int, sensor_id: int) -> float | None:
    [r] = [r for r in batch.readings if r.robot_id == robot_id]
    return r.proximity_m[r.proximity_ids.index(sensor_id)]


def test_an_obstacle_drawn_on_the_page_is_in_the_world_and_in_a_chairs_readings(
    live: tuple[Net, ZenohBus, str], browser: Browser
) -> None:
    net, bus, url = live
    page = _open(browser, url, len(CHAIRS))
    sensors = subscribe(bus, keys.all_sensor_batches(net.sim))
    infos = subscribe(bus, keys.info(net.sim))
    paused = _pause(page, bus, net.sim)
    # the readings of the tick the world paused at may have gone out before this test's
    # subscription reached the router (CI: no batch within 20 s): one step makes a tick of its own
    page.click("#btn-step")
    stopped = paused + 1
    page.wait_for_function(f"window.iwz.world.tick === {stopped}", timeout=WAIT_MS)
    chair = next(
        r for r in _robots(page).values() if page.evaluate(f"window.iwz.world.robots.get({r['id']}).name") == "south"
    )
    front = page.evaluate(f"window.iwz.world.robots.get({chair['id']}).sensors.find((s) => s.angle_deg === 0).id")
    before = wait_msg(sensors, SensorBatch, lambda b: b.tick >= stopped and chair["id"] in b.ids)
    seen_before = _front(before, chair["id"], front)
    assert seen_before is None or seen_before > 2.5  # nothing ahead in the open lab

    ahead_x = chair["x"] + 1.4 * math.cos(chair["heading"])
    ahead_y = chair["y"] + 1.4 * math.sin(chair["heading"])
    _drag_box(page, ahead_x - 0.2, ahead_y - 0.6, ahead_x + 0.2, ahead_y + 0.6)
    info = wait_msg(infos, WorldInfo, lambda i: any(o.name == "page-1" for o in i.obstacles))
    [ob] = [o for o in info.obstacles if o.name == "page-1"]
    assert ob.x0 == pytest.approx(ahead_x - 0.2, abs=0.05)
    assert ob.y1 == pytest.approx(ahead_y + 0.6, abs=0.05)
    page.wait_for_function("window.iwz.world.scene.obstacles.some((o) => o.name === 'page-1')", timeout=WAIT_MS)

    page.click("#btn-step")
    after = wait_msg(sensors, SensorBatch, lambda b: b.tick > stopped and chair["id"] in b.ids)
    seen = _front(after, chair["id"], front)
    assert seen is not None
    assert seen < 1.4
    page.click("#btn-start")
    page.close()


def test_an_obstacle_dragged_on_the_page_moves_in_the_world_and_delete_removes_it(
    live: tuple[Net, ZenohBus, str], browser: Browser
) -> None:
    net, bus, url = live
    page = _open(browser, url, len(CHAIRS))
    infos = subscribe(bus, keys.info(net.sim))
    _drag_box(page, 20.0, 10.0, 21.0, 11.0)  # in a corner no chair drives through
    wait_msg(infos, WorldInfo, lambda i: any(o.x0 == pytest.approx(20.0, abs=0.05) for o in i.obstacles))
    page.wait_for_function("window.iwz.world.scene.obstacles.some((o) => Math.abs(o.x0 - 20) < 0.05)", timeout=WAIT_MS)
    name = page.evaluate("window.iwz.world.scene.obstacles.find((o) => Math.abs(o.x0 - 20) < 0.05).name")
    box = page.locator("#view2d").bounding_box()
    assert box is not None
    a = page.evaluate("window.iwz.toScreen(20.5, 10.5)")
    b = page.evaluate("window.iwz.toScreen(23.5, 10.5)")  # 3 m east, still clear of the chairs' lanes
    page.mouse.move(box["x"] + a[0], box["y"] + a[1])
    page.mouse.down()
    page.mouse.move(box["x"] + (a[0] + b[0]) / 2, box["y"] + (a[1] + b[1]) / 2)
    page.mouse.move(box["x"] + b[0], box["y"] + b[1])
    page.mouse.up()
    moved = wait_msg(infos, WorldInfo, lambda i: any(o.name == name and o.x0 > 22 for o in i.obstacles))
    [ob] = [o for o in moved.obstacles if o.name == name]
    assert (ob.x0, ob.y0, ob.x1, ob.y1) == pytest.approx((23.0, 10.0, 24.0, 11.0), abs=0.05)

    c = page.evaluate("window.iwz.toScreen(23.5, 10.5)")
    page.wait_for_function(f"window.iwz.world.scene.obstacles.some((o) => o.name === '{name}' && o.x0 > 22)")
    page.mouse.click(box["x"] + c[0], box["y"] + c[1])
    page.wait_for_selector("#btn-obstacle-delete:not([hidden])", timeout=WAIT_MS)
    page.click("#btn-obstacle-delete")
    wait_msg(infos, WorldInfo, lambda i: all(o.name != name for o in i.obstacles))
    page.wait_for_function(f"!window.iwz.world.scene.obstacles.some((o) => o.name === '{name}')", timeout=WAIT_MS)
    page.close()


def test_the_3d_view_is_not_blank_in_first_person(live: tuple[Net, ZenohBus, str], browser: Browser) -> None:
    _, _, url = live
    page = _open(browser, url, len(CHAIRS))
    page.select_option("#view-mode", "first")
    page.wait_for_function("window.iwz.view3d() && window.iwz.view3d().drawn > 2", timeout=WAIT_MS)
    got = page.evaluate("window.iwz.coverage()")
    assert got["covered"] > 0.3, got  # the floor and the lab's edge fill much of a first-person view
    assert got["colours"] >= 3, got
    page.close()


def test_a_viewer_started_after_the_registrations_names_each_chairs_agent(
    live: tuple[Net, ZenohBus, str], browser: Browser
) -> None:
    net, bus, _ = live
    wait_msg(subscribe(bus, keys.state(net.sim)), WorldState, lambda s: len(s.ids) == len(CHAIRS))
    late = net.spawn("view", "--port", "0", "--foxglove-port", "0", name="view-late")  # saw no registered event
    page = _open(browser, viewer_url(late), len(CHAIRS))
    agents = page.evaluate("Object.fromEntries([...window.iwz.world.robots.values()].map((r) => [r.name, r.agent]))")
    assert agents == {name: name for name in CHAIRS}  # each chair's agent process is named after it
    target = next(iter(_robots(page).values()))
    name = page.evaluate(f"window.iwz.world.robots.get({target['id']}).name")
    box = page.locator("#view2d").bounding_box()
    assert box is not None
    _pause(page, bus, net.sim)  # the chair stays where it is clicked
    target = _robots(page)[target["id"]]
    sx, sy = page.evaluate(f"window.iwz.toScreen({target['x']}, {target['y']})")
    page.mouse.click(box["x"] + sx, box["y"] + sy)
    page.wait_for_function(  # the panel's agent row
        "(n) => [...document.querySelectorAll('#panel-body tr')].some("
        "(tr) => tr.cells[0].textContent === 'agent' && tr.cells[1].textContent === n)",
        arg=name,
        timeout=WAIT_MS,
    )
    page.click("#btn-start")
    late.kill(signal.SIGTERM)
    page.close()


def test_removing_a_robot_on_the_page_removes_it_from_the_world(
    live: tuple[Net, ZenohBus, str], browser: Browser
) -> None:
    net, bus, url = live
    page = _open(browser, url, len(CHAIRS))
    events = subscribe(bus, keys.all_events(net.sim))
    _pause(page, bus, net.sim)
    target = next(iter(_robots(page).values()))
    box = page.locator("#view2d").bounding_box()
    assert box is not None
    sx, sy = page.evaluate(f"window.iwz.toScreen({target['x']}, {target['y']})")
    page.mouse.click(box["x"] + sx, box["y"] + sy)
    page.wait_for_selector("#panel:not([hidden])", timeout=WAIT_MS)
    assert f"robot {target['id']}" in page.inner_text("#panel-title")
    page.click("#btn-remove")
    wait_event(events, "removed", pred=lambda e: e.robot_id == target["id"])
    states = subscribe(bus, keys.state(net.sim))
    page.click("#btn-start")
    after = wait_msg(states, WorldState)
    assert target["id"] not in after.ids
    page.wait_for_function(f"!window.iwz.world.ids.includes({target['id']}) && window.iwz.world.ids.length === 2")
    page.close()


@pytest.fixture
def replay(tmp_path: Path) -> Iterator[str]:
    """``iwz view`` replaying the sample recording (no router: a replay needs none)."""
    net = Net(tmp_path, sim="default")
    try:
        yield viewer_url(net.spawn("view", str(SAMPLE), "--port", "0", connect=False))
    finally:
        net.close()


def test_replay_seeks_to_a_time_and_shows_the_poses_recorded_at_that_tick(replay: str, browser: Browser) -> None:
    with open_recording(SAMPLE) as rec:
        states = [r.message for r in rec.records(("state",)) if isinstance(r.message, WorldState)]
    page = _open(browser, replay, 3)
    page.click("#btn-pause")
    page.wait_for_function("window.iwz.world.timeline && !window.iwz.world.timeline.playing", timeout=WAIT_MS)
    track = page.locator("#tl-range").bounding_box()
    assert track is not None
    page.mouse.click(track["x"] + track["width"] * 0.6, track["y"] + track["height"] / 2)  # a click on the track seeks
    seek = page.wait_for_function(
        "window.iwz.sent.filter((c) => c.cmd === 'seek').map((c) => c.at_ns).pop()", timeout=WAIT_MS
    ).json_value()
    want = next(s for s in states if s.sim_time_ns >= seek)
    page.wait_for_function(f"window.iwz.world.tick === {want.tick}", timeout=WAIT_MS)
    shown = _robots(page)
    for i, rid in enumerate(want.ids):
        assert shown[rid]["x"] == pytest.approx(want.x[i], abs=1e-3)
        assert shown[rid]["y"] == pytest.approx(want.y[i], abs=1e-3)
        assert shown[rid]["heading"] == pytest.approx(want.heading[i], abs=1e-3)

    page.click("#btn-step")  # one tick further, and no more
    following = states[states.index(want) + 1]
    page.wait_for_function(f"window.iwz.world.tick === {following.tick}", timeout=WAIT_MS)
    assert not page.evaluate("window.iwz.world.timeline.playing")
    page.select_option("#rate", "2")
    page.wait_for_function("window.iwz.world.timeline.rate === 2", timeout=WAIT_MS)
    marks = page.locator("#tl-marks span").count()
    assert marks > 0  # the sample's incidents are on the timeline
    first = page.evaluate("window.iwz.world.timeline.marks[0].t_ns")
    page.locator("#tl-marks span").first.click()  # jumps a second before the incident
    page.wait_for_function(
        f"window.iwz.sent.filter((c) => c.cmd === 'seek').pop().at_ns === Math.max({states[0].sim_time_ns}, {first} - 1e9)",
        timeout=WAIT_MS,
    )
    before = next(s for s in states if s.sim_time_ns >= max(states[0].sim_time_ns, first - 10**9))
    page.wait_for_function(f"window.iwz.world.tick === {before.tick}", timeout=WAIT_MS)
    page.close()
