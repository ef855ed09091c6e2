"""Driving from the page, in headless Chromium: the latency from a key event in the page to the
world's command, and the page's frame rate while driving in first person.

    python benchmarks/drive.py            # about 40 s
    python benchmarks/drive.py --quick    # about 20 s, fewer presses and a shorter window
    python benchmarks/drive.py --json

Real processes, in real time at 20 ticks a second: a router, the world, collision, sensors, one
chair whose ``manual`` agent accepts a driver, and ``iwz view``; Debian's Chromium (software
WebGL, as the tests) opens ``?drive=ID``, so the page drives the chair in first person. The
benchmark then presses and releases the up and down arrows in turn (the chair goes forward, stops,
goes back, stops); for each key event it takes the event's own time in the page (its
``timeStamp`` on the wall clock) and the arrival, at this process's own subscriber, of the first
``Actions`` of the chair's agent that obeys it (moving after a press, zero after a release):
the latency from the key to the command the world is given (page, WebSocket, viewer, bus, the
agent's next tick; the world ticks every 50 ms, so a tick's wait is part of it). Printed: p50 and
p99 over every key event. Then, still driving in first person, the frames the page draws a second
over a window (its 3D view's own count of drawings, and the browser's animation frames).

Goals (issue 35): latency p99 <= 60 ms; >= 30 frames a second in first person.

Measured once with ``--quick`` (20 key events, a 3 s window) on the shared two-core machine while
seven other engineers ran their tests (load average 19 to 30): latency p50 106.9 ms, p99 313.0 ms;
5.0 drawings a second of the 3D view (5.3 animation frames). Both goals are missed there; an
unloaded reference run is still to be made, so read these as a loaded machine's floor, not the
page's figures.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import exit_on_sigterm, stop_all  # noqa: E402
from benchmarks.chromium import CHROMIUM, INSTALL, launch  # noqa: E402
from iw_zenoh import keys  # noqa: E402
from iw_zenoh.bus import Inbox, ZenohBus  # noqa: E402
from iw_zenoh.bus.net import NetConfig, free_port, port_in_use  # noqa: E402
from iw_zenoh.messages import Actions, DriveState, decode  # noqa: E402

SIM = "drivebench"
AGENT = "driven"
LAB = '<Lab Name="open" Width="30" Height="10"/>'
GOAL_P99_MS, GOAL_FPS = 60.0, 30.0
# in the page: each arrow key event's wall-clock time (ms since the epoch), in order
STAMP = """
window.__keys = [];
const stamp = (e) => { if (!e.repeat) window.__keys.push(performance.timeOrigin + e.timeStamp); };
window.addEventListener("keydown", stamp, true);
window.addEventListener("keyup", stamp, true);
window.__frames = 0;
const count = () => { window.__frames += 1; requestAnimationFrame(count); };
requestAnimationFrame(count);
"""
# the animation frames so far, and the drawings of the page's 3D view (its own count)
FRAMES = "[window.__frames, window.iwz && window.iwz.view3d() ? window.iwz.view3d().drawn : 0]"


def _spawn(tmp: Path, procs: list[subprocess.Popen[bytes]], name: str, args: list[str]) -> Path:
    log = tmp / f"{name}.log"
    with log.open("wb") as f:
        argv = [sys.executable, "-m", "iw_zenoh.cli", *args]
        procs.append(subprocess.Popen(argv, stdout=f, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL))
    return log


def _start(tmp: Path, procs: list[subprocess.Popen[bytes]]) -> tuple[str, str]:
    """The run and the viewer; the router's endpoint and the page's address."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    _spawn(tmp, procs, "router", ["router", "--listen", endpoint, "--sim", SIM])
    deadline = time.monotonic() + 20
    while not port_in_use(port):
        assert time.monotonic() < deadline, "the router did not listen in 20 s"
        time.sleep(0.02)  # polling a port: there is no event to wait on
    (tmp / "lab.xml").write_text(LAB)
    common = ["--sim", SIM, "-e", endpoint]
    _spawn(tmp, procs, "world", ["world", str(tmp / "lab.xml"), "--period-ms", "50", *common])
    for role in ("collision", "sensors"):
        _spawn(tmp, procs, role, [role, *common])
    _spawn(tmp, procs, AGENT, ["agent", "manual", "--start", "5,5,0", "--robot-name", AGENT, "--name", AGENT, *common])
    log = _spawn(tmp, procs, "view", ["view", "--port", "0", "--no-foxglove", *common])
    while not (m := re.search(r"iwz view: (http://\S+/)", log.read_text())):
        assert procs[-1].poll() is None, f"iwz view died:\n{log.read_text()}"
        assert time.monotonic() < deadline + 60, "iwz view did not serve in time"
        time.sleep(0.05)  # polling its log: there is no event to wait on
    return endpoint, m.group(1)


def _chair(bus: ZenohBus) -> int:
    """The driven chair's id, once its agent tells its drive state."""
    drives = Inbox()
    bus.subscribe(keys.all_driving(SIM), drives)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        got = drives.get(timeout_s=1.0)
        if got is not None:
            return decode(got[1], DriveState).robot_id
    raise AssertionError("no chair told its drive state within 60 s")


def _obeys(box: Inbox, rid: int, moving: bool, timeout_s: float = 5.0) -> float:
    """The wall time (ms) the first batch of the chair's actions that is moving (or zero) arrived."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        got = box.get(timeout_s=0.5)
        if got is None:
            continue
        a = decode(got[1], Actions)
        if a.robot_id == rid and (abs(a.left) + abs(a.right) > 1e-4) == moving:
            return got[2] / 1e6
    raise AssertionError(f"the chair's agent did not {'move' if moving else 'stop'} within {timeout_s} s")


def run(presses: int, window_s: float) -> dict[str, float]:
    """The latencies of ``presses`` press-and-release pairs, then the frame rate over ``window_s``."""
    from playwright.sync_api import sync_playwright

    procs: list[subprocess.Popen[bytes]] = []
    with tempfile.TemporaryDirectory() as d:
        try:
            endpoint, url = _start(Path(d), procs)
            with ZenohBus(NetConfig(connect=(endpoint,))) as bus, sync_playwright() as p:
                rid = _chair(bus)
                actions = Inbox()  # one robot's agent sends its actions on the robot's own key
                bus.subscribe(keys.actions(SIM, rid), actions)
                browser = launch(p)
                try:
                    page = browser.new_page(viewport={"width": 1280, "height": 800})
                    page.add_init_script(STAMP)
                    page.goto(f"{url}?hooks=1&drive={rid}")
                    page.wait_for_function(
                        "document.getElementById('drive-status').textContent.startsWith('you drive')", timeout=60_000
                    )
                    got: list[float] = []
                    for k in range(presses):
                        key = "ArrowUp" if k % 2 == 0 else "ArrowDown"
                        actions.drain()
                        page.keyboard.down(key)
                        moved = _obeys(actions, rid, True)
                        page.wait_for_timeout(150)  # it drives a little
                        actions.drain()
                        page.keyboard.up(key)
                        stopped = _obeys(actions, rid, False)
                        pressed, released = page.evaluate("window.__keys.splice(0)")[-2:]
                        got += [moved - pressed, stopped - released]
                    f0, d0 = page.evaluate(FRAMES)
                    t0 = time.monotonic()
                    page.keyboard.down("ArrowUp")  # driving while the frames are counted
                    page.wait_for_timeout(window_s * 1000)
                    f1, d1 = page.evaluate(FRAMES)
                    elapsed = time.monotonic() - t0
                    page.keyboard.up("ArrowUp")
                finally:
                    browser.close()
        finally:
            stop_all(procs)
    lat = np.array(got)
    return {
        "key_events": len(got),
        "latency_p50_ms": float(np.percentile(lat, 50)),
        "latency_p99_ms": float(np.percentile(lat, 99)),
        "latency_max_ms": float(lat.max()),
        "animation_frames_per_s": (f1 - f0) / elapsed,
        "drawn_per_s": (d1 - d0) / elapsed,
    }


def main() -> int:
    """Runs the benchmark and prints its figures."""
    exit_on_sigterm()
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="10 presses and a 3 s window instead of 40 and 10 s")
    p.add_argument("--json", action="store_true", help="print JSON")
    args = p.parse_args()
    if not CHROMIUM.exists():
        print(f"benchmarks/drive.py: {CHROMIUM} is missing: {INSTALL}", file=sys.stderr)
        return 2
    r = run(10 if args.quick else 40, 3.0 if args.quick else 10.0)
    if args.json:
        print(json.dumps(r, indent=2))
        return 0
    print(f"key event -> the world's command, over {r['key_events']} key events (20 Hz, real time):")
    print(f"  p50 {r['latency_p50_ms']:.1f} ms, p99 {r['latency_p99_ms']:.1f} ms, max {r['latency_max_ms']:.1f} ms")
    print(
        f"first person while driving: {r['drawn_per_s']:.1f} drawings/s of the 3D view, "
        f"{r['animation_frames_per_s']:.1f} animation frames/s"
    )
    print(f"goals: latency p99 <= {GOAL_P99_MS:g} ms; >= {GOAL_FPS:g} frames/s in first person")
    return 0


if __name__ == "__main__":
    sys.exit(main())
