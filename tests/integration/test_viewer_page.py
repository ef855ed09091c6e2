"""How the page looks and behaves for a person (issue 35's items 2 and 3, issue 31's item 6), in
Debian's Chromium on a live run: a router, world, collision, sensors, two standing chairs (one with
a 3 m wall right behind it, the other facing it 3 m ahead) and ``iwz view``, each its own process.

Screenshots of the driving view, the 2D view with its legend and the robot panel go to
``$IWZ_SHOTS`` (default: the test's temporary directory)."""

from __future__ import annotations

import base64
import json
import math
import os
import re
import struct
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from playwright.sync_api import Browser, Dialog, Page

from iw_zenoh.messages import WorldState
from iw_zenoh.record.reader import open_recording
from tests.integration.browser import hooked, viewer_url
from tests.integration.harness import ROOT, Net

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

LAB = """<Lab Name="page" Width="20" Height="10">
  <Wall Height="3.0"><Corner X="0.5" Y="3"/><Corner X="1" Y="3"/><Corner X="1" Y="7"/><Corner X="0.5" Y="7"/></Wall>
</Lab>"""  # a wall whose east face is 1 m behind the chair "front" (at x = 2, facing east)
CHAIRS = {"front": ("2,5,0", "2,5"), "other": ("5,5,180", "5,5")}  # they stand where they start
SAMPLE = ROOT / "recordings" / "demo-sample.mcap"
WAIT_MS = 30_000


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Net, str]]:
    """The live run and its page's address."""
    net = Net(tmp_path_factory.mktemp("page"), sim="page")
    net.start_router()
    try:
        (net.tmp / "lab.xml").write_text(LAB)
        net.spawn("world", str(net.tmp / "lab.xml"))
        for role in ("collision", "sensors"):
            net.spawn(role)
        for name, (start, waypoints) in CHAIRS.items():
            net.spawn(
                "agent", "waypoint", "--waypoints", waypoints, "--start", start, "--robot-name", name, "--name", name
            )
        yield net, viewer_url(net.spawn("view", "--port", "0", "--no-foxglove"))
    finally:
        net.close()


@pytest.fixture(scope="module")
def shots(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Where the screenshots go."""
    where = Path(os.environ.get("IWZ_SHOTS") or tmp_path_factory.mktemp("shots"))
    where.mkdir(parents=True, exist_ok=True)
    return where


def _open(browser: Browser, url: str) -> Page:
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.goto(hooked(url))
    page.wait_for_function(f"window.iwz && window.iwz.world.ids.length === {len(CHAIRS)}", timeout=WAIT_MS * 2)
    return page


def _id(page: Page, name: str) -> int:
    return int(page.evaluate(f"[...window.iwz.world.robots.values()].find((r) => r.name === '{name}').id"))


def _click_robot(page: Page, name: str) -> None:
    rid = _id(page, name)
    box = page.locator("#view2d").bounding_box()
    assert box is not None
    sx, sy = page.evaluate(f"((r) => window.iwz.toScreen(r.x, r.y))(window.iwz.robots().find((r) => r.id === {rid}))")
    page.mouse.click(box["x"] + sx, box["y"] + sy)
    page.wait_for_function(f"window.iwz.world.selected && window.iwz.world.selected.id === {rid}", timeout=WAIT_MS)


def test_the_page_has_no_test_hooks_unless_its_address_asks(live: tuple[Net, str], browser: Browser) -> None:
    _, url = live
    page = browser.new_page()
    asked: list[str] = []
    page.on("request", lambda r: asked.append(r.url))
    page.goto(url)
    page.wait_for_function(f"document.getElementById('hud-robots').textContent === '{len(CHAIRS)} robots'")
    assert page.evaluate("typeof window.iwz") == "undefined"
    assert not any(u.endswith("/hooks.js") for u in asked), asked
    page.close()
    page = _open(browser, url)  # ?hooks=1
    assert page.evaluate("typeof window.iwz.toScreen") == "function"
    # names, not letters; waited for, as a busy machine may show them held while collision catches
    # up (and taken from the same moment: a second look may catch the next late verdict)
    states = page.wait_for_function(
        "(() => { const s = window.iwz.robots().map((r) => r.state);"
        f" return s.length === {len(CHAIRS)} && s.every((x) => x === 'driving') ? s : null; }})()",
        timeout=WAIT_MS,
    ).json_value()
    assert states == ["driving", "driving"]
    page.close()


def test_the_map_has_a_legend_a_scale_bar_and_the_cursors_coordinates_and_3d_is_one_key_away(
    live: tuple[Net, str], browser: Browser, shots: Path
) -> None:
    _, url = live
    page = _open(browser, url)
    legend = page.inner_text("#legend")
    for means in ("driving", "held", "watchdog", "collided", "door", "wall", "obstacle", "laser hit", "target"):
        assert means in legend, legend
    assert page.is_visible("#legend")
    page.wait_for_function("window.iwz.scaleBar() > 0", timeout=WAIT_MS)  # set when the map is first drawn
    metres, px = page.evaluate("[window.iwz.scaleBar(), window.iwz.scaleBar() * window.iwz.scale()]")
    mantissa = metres / 10 ** math.floor(math.log10(metres))
    assert round(mantissa, 6) in (1, 2, 5), metres  # a round length
    assert 50 <= px <= 300, px
    box = page.locator("#view2d").bounding_box()
    assert box is not None
    sx, sy = page.evaluate("window.iwz.toScreen(7.25, 2.5)")
    page.mouse.move(box["x"] + sx, box["y"] + sy)
    page.wait_for_function("document.getElementById('cursor').textContent.startsWith('x ')", timeout=WAIT_MS)
    m = re.fullmatch(r"x (\S+) m\s+y (\S+) m", page.inner_text("#cursor"))
    assert m, page.inner_text("#cursor")
    pixel_m = 1.5 / page.evaluate("window.iwz.scale()")  # the mouse lands on whole pixels
    assert float(m.group(1)) == pytest.approx(7.25, abs=pixel_m)
    assert float(m.group(2)) == pytest.approx(2.5, abs=pixel_m)
    page.screenshot(path=str(shots / "map-legend.png"))

    page.keyboard.press("1")
    page.wait_for_function("!document.getElementById('view3d').hidden && window.iwz.view3d().drawn > 0")
    assert not page.is_visible("#legend")
    page.keyboard.press("m")  # back to the map
    page.wait_for_function("!document.getElementById('view2d').hidden")
    page.keyboard.press("m")  # and to the last 3D view
    page.wait_for_function("document.getElementById('view-mode').value === 'first'")
    page.keyboard.press("2")
    page.wait_for_function("document.getElementById('view-mode').value === '2d'")
    page.close()


def test_the_robot_panel_leaves_the_whole_map_in_view_and_reads_as_a_table(
    live: tuple[Net, str], browser: Browser, shots: Path
) -> None:
    _, url = live
    page = _open(browser, url)
    _click_robot(page, "other")
    page.wait_for_selector("#panel:not([hidden])", timeout=WAIT_MS)
    # the map re-fits into what the panel leaves: the lab's far corner is on the canvas
    page.wait_for_function(
        "(() => { const c = document.getElementById('view2d').getBoundingClientRect();"
        " const [x, y] = window.iwz.toScreen(20, 0); return x <= c.width && y <= c.height; })()",
        timeout=WAIT_MS,
    )
    page.wait_for_function("document.querySelectorAll('#panel-body table.sensors tr').length > 1", timeout=WAIT_MS)
    text = page.inner_text("#panel-body")
    assert "{" not in text, text  # no raw JSON
    assert "[" not in text, text
    rows = dict(
        page.evaluate(
            "[...document.querySelectorAll('#panel-body table.spec tr')].map((tr) => [tr.cells[0].textContent, tr.cells[1].textContent])"
        )
    )
    assert rows["top speed"].endswith(" m/s"), rows
    assert rows["length (along the heading)"].endswith(" m"), rows
    sensors = page.evaluate(
        "[...document.querySelectorAll('#panel-body table.sensors')[0].rows].slice(1).map((tr) => tr.cells[4].textContent)"
    )
    assert sensors, "no sensor rows"
    assert all(s.endswith(" m") for s in sensors), sensors  # one row a sensor, with its range's unit
    page.wait_for_function(
        "[...document.querySelectorAll('#panel-body tr')].some((tr) => tr.cells[0].textContent === 'speed'"
        " && tr.cells[1].textContent.endsWith('m/s'))",
        timeout=WAIT_MS,
    )
    page.screenshot(path=str(shots / "robot-panel.png"))
    page.click("#panel-close")
    page.wait_for_function(
        "(() => { const c = document.getElementById('view2d').getBoundingClientRect();"
        " return window.iwz.toScreen(20, 0)[0] > c.width - 80; })()",  # and fills the width again
        timeout=WAIT_MS,
    )
    page.close()


def test_first_person_is_lit_shows_the_chair_ahead_and_a_hud_to_drive_by(
    live: tuple[Net, str], browser: Browser, shots: Path
) -> None:
    _, url = live
    page = _open(browser, url)
    page.evaluate(f"window.iwz.follow({_id(page, 'front')})")
    page.keyboard.press("1")
    page.wait_for_function("window.iwz.view3d() && window.iwz.view3d().drawn > 1", timeout=WAIT_MS)
    got = page.evaluate("window.iwz.coverage()")
    assert got["covered"] > 0.3, got
    assert got["colours"] >= 12, got  # shaded faces, a grid, coloured solids: many tones, not three flat greys
    # the chair ahead (3 m, its frame in its state's green) comes into view: nothing else is green
    # (waited for, not sampled at the second frame: in CI, on a loaded machine, that frame had no
    # green at all; a chair is drawn in its state's colour, green only while it is driving)
    page.wait_for_function("window.iwz.count3d((r, g, b) => g > r + 30 && g > b + 15) > 0.002", timeout=WAIT_MS)
    # the nearest obstacle once the chair's readings have reached the page (drawn each animation frame)
    page.wait_for_function(
        "['front', 'm/s', 'nearest obstacle'].every((s) => document.getElementById('drivehud').innerText.includes(s))",
        timeout=WAIT_MS,
    )
    hud = page.inner_text("#drivehud")
    for said in ("front", "m/s", "nearest obstacle"):
        assert said in hud, hud
    page.evaluate(
        "window.iwz.driveHud.show({robot: window.iwz.view3d().followId, driver: 'page-1', you: true, level: 3,"
        " assist: 'safe', v_mps: 0.42, w_radps: 0.1, intervened: true, nearest_m: 0.35, stale: false})"
    )
    page.wait_for_function("document.querySelector('#drivehud .hud-assist.intervened') !== null", timeout=WAIT_MS)
    hud = page.inner_text("#drivehud")
    for said in ("0.42", "3/5", "safe", "stepped in", "you drive"):
        assert said in hud, hud
    assert page.locator("#drivehud .hud-near.danger").count() == 1  # 0.35 m: a red warning
    page.screenshot(path=str(shots / "driving-first-person.png"))
    page.close()


def test_third_person_and_free_cameras_never_sit_inside_a_wall(
    live: tuple[Net, str], browser: Browser, shots: Path
) -> None:
    _, url = live
    page = _open(browser, url)
    page.evaluate(f"window.iwz.follow({_id(page, 'front')})")
    page.keyboard.press("3")
    page.wait_for_function("window.iwz.view3d() && window.iwz.view3d().drawn > 1", timeout=WAIT_MS)
    eye = page.evaluate("window.iwz.view3d().eye")
    # 4 m behind the chair (x = 2) would be at x = -2, through the 3 m wall whose face is at x = 1
    assert eye[0] > 1.0 + 0.2, eye
    assert eye[0] < 2.0, eye
    page.screenshot(path=str(shots / "third-person.png"))
    page.keyboard.press("4")
    page.evaluate(
        "(() => { const v = window.iwz.view3d(); Object.assign(v.free, {tx: 0.75, ty: 5, yaw: 0, pitch: 0.05, dist: 0.01});"
        " v.moved(); })()"
    )  # an orbit whose eye falls inside the wall
    page.wait_for_function("window.iwz.view3d().eye[2] >= 3.0", timeout=WAIT_MS)
    page.close()


def _stl_box(length: float, width: float, height: float) -> bytes:
    """A binary STL of a box (12 triangles)."""
    v = [(x, y, z) for x in (0, length) for y in (0, width) for z in (0, height)]
    faces = [
        (0, 1, 3),
        (0, 3, 2),
        (4, 6, 7),
        (4, 7, 5),
        (0, 4, 5),
        (0, 5, 1),
        (2, 3, 7),
        (2, 7, 6),
        (0, 2, 6),
        (0, 6, 4),
        (1, 5, 7),
        (1, 7, 3),
    ]
    out = bytearray(b"iwz test box".ljust(80, b" ")) + struct.pack("<I", len(faces))
    for f in faces:
        out += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *v[i]) for i in f) + b"\0\0"
    return bytes(out)


def test_a_model_file_per_robot_type_stands_in_for_the_built_in_chair(live: tuple[Net, str], browser: Browser) -> None:
    net, _ = live
    models = net.tmp / "models"
    models.mkdir()
    (models / "simulated.stl").write_bytes(_stl_box(2.0, 1.0, 4.0))
    (models / "notes.txt").write_text("not a model: not listed")
    url = viewer_url(net.spawn("view", "--port", "0", "--no-foxglove", "--models", str(models), name="view-models"))
    page = _open(browser, url)
    assert page.evaluate("fetch('/models/index.json').then((r) => r.json())") == ["simulated.stl"]
    page.keyboard.press("3")
    page.wait_for_function("window.iwz.view3d() && window.iwz.view3d().models.has('simulated')", timeout=WAIT_MS)
    shape = page.evaluate(
        "(() => { const v = window.iwz.view3d(); const f = v.shape([...window.iwz.world.robots.values()][0]).frame;"
        " const z = f.filter((_, i) => i % 3 === 2); return [f.length, Math.max(...z)]; })()"
    )
    assert shape[0] == 12 * 9  # the box's 12 triangles
    assert shape[1] > 1.0  # its proportions kept: a box four times as tall as wide stands tall
    page.close()


def test_remove_and_stop_ask_first(live: tuple[Net, str], browser: Browser) -> None:
    _, url = live
    page = _open(browser, url)
    said: list[str] = []

    def dismiss(d: Dialog) -> None:
        said.append(d.message)
        d.dismiss()

    page.on("dialog", dismiss)
    page.click("#btn-stop")
    _click_robot(page, "other")
    page.click("#btn-remove")
    assert len(said) == 2, said
    assert "Stop the simulation" in said[0]
    assert "Remove robot" in said[1]
    assert "other" in said[1]
    assert page.evaluate("window.iwz.sent.filter((c) => c.cmd === 'stop' || c.cmd === 'remove').length") == 0
    page.remove_listener("dialog", dismiss)
    page.once("dialog", lambda d: d.accept())
    page.click("#btn-remove")  # asked, and said yes: removed
    page.wait_for_function(f"window.iwz.world.ids.length === {len(CHAIRS) - 1}", timeout=WAIT_MS)
    page.close()


@pytest.fixture
def replay(tmp_path: Path) -> Iterator[str]:
    """``iwz view`` replaying the sample recording."""
    net = Net(tmp_path, sim="default")
    try:
        yield viewer_url(net.spawn("view", str(SAMPLE), "--port", "0", connect=False))
    finally:
        net.close()


def test_a_replay_opens_paused_at_its_start_with_its_incidents_marked_and_explained(
    replay: str, browser: Browser
) -> None:
    with open_recording(SAMPLE) as rec:
        states = [r.message for r in rec.records(("state",)) if isinstance(r.message, WorldState)]
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.goto(hooked(replay))
    page.wait_for_function(f"window.iwz && window.iwz.world.tick === {states[0].tick}", timeout=WAIT_MS * 2)
    page.wait_for_function("window.iwz.world.timeline !== null", timeout=WAIT_MS)
    assert page.evaluate("window.iwz.world.timeline.playing") is False
    assert page.evaluate("window.iwz.world.timeline.position_ns") == states[0].sim_time_ns
    assert "paused" in page.inner_text("#hud-mode")
    marks = page.locator("#tl-marks span")
    assert marks.count() > 0
    first = marks.first.bounding_box()
    assert first is not None
    assert first["width"] >= 5  # visible, not a hairline
    assert first["height"] >= 12
    explain = page.inner_text("#tl-explain")
    assert "incidents:" in explain, explain
    assert "click" in explain, explain
    kinds = page.evaluate("[...new Set(window.iwz.world.timeline.marks.map((m) => m.kind))]")
    assert any(k.replace("-", " ") in explain for k in kinds), (kinds, explain)
    assert "click" in (marks.first.get_attribute("title") or "")
    page.close()


GLTF_TRIANGLE = {  # one triangle, y up (glTF's), its buffer in a data URI
    "asset": {"version": "2.0"},
    "buffers": [
        {
            "byteLength": 36,
            "uri": "data:application/octet-stream;base64,"
            + base64.b64encode(struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)).decode(),
        }
    ],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
}


@pytest.fixture(scope="module")
def readers(live: tuple[Net, str], browser: Browser) -> Iterator[Page]:
    """A page of the live viewer, for models.js's readers."""
    page = browser.new_page()
    page.goto(live[1])
    yield page
    page.close()


def _read(page: Page, kind: str, data: bytes) -> str:
    """models.js's reader of ``kind`` ("stl" or "gltf") on ``data``: "ok N" (N numbers read) or the
    error's name and message."""
    return str(
        page.evaluate(
            """async ([kind, bytes]) => {
                const m = await import('/static/models.js');
                const buf = new Uint8Array(bytes).buffer;
                try {
                    const got = kind === 'stl' ? m.parseStl(buf) : await m.parseGltf(buf, location.href);
                    return `ok ${got.tris.length}`;
                } catch (e) { return `${e.name}: ${e.message}`; }
            }""",
            [kind, list(data)],
        )
    )


def test_the_model_readers_read_stl_and_gltf_and_turn_gltf_z_up(readers: Page) -> None:
    assert _read(readers, "stl", _stl_box(1, 1, 1)) == "ok 108"
    ascii_stl = b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n"
    assert _read(readers, "stl", ascii_stl) == "ok 9"
    assert _read(readers, "gltf", json.dumps(GLTF_TRIANGLE).encode()) == "ok 9"
    up = readers.evaluate(
        """async (text) => { const m = await import('/static/models.js');
            return Array.from((await m.parseGltf(new TextEncoder().encode(text).buffer, location.href)).tris); }""",
        json.dumps(GLTF_TRIANGLE),
    )
    assert up[6:9] == [0, 0, 1]  # glTF's (0, 1, 0), y up, is z up here


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    data=st.one_of(
        st.binary(max_size=300),
        st.builds(lambda b, cut: b[:cut], st.just(_stl_box(1, 2, 3)), st.integers(0, 700)),
        st.builds(lambda n: b"x" * 80 + struct.pack("<I", n) + b"\0" * 50, st.integers(0, 2**32 - 1)),
        st.builds(lambda t: f"solid a\nvertex {t}\n".encode(), st.text(max_size=40)),
    ),
    kind=st.sampled_from(["stl", "gltf"]),
)
def test_the_model_readers_refuse_garbage_with_a_reason_and_never_hang(readers: Page, data: bytes, kind: str) -> None:
    got = _read(readers, kind, data)
    if got.startswith("ok "):
        assert int(got[3:]) % 9 == 0, got  # whole triangles only
    else:
        assert ": " in got, got  # an error with its name and a message
        assert len(got) > len("Error: "), got
