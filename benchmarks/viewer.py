"""The viewer's page in headless Chromium: frames drawn a second with 100 and 1,000 chairs, and the
delay from a tick's start to its drawing.

    python benchmarks/viewer.py            # about 40 s
    python benchmarks/viewer.py --quick    # about 15 s, shorter windows
    python benchmarks/viewer.py --json

Real processes: a router and ``iwz view``; this script plays the world (answers ``world/info``
and publishes a tick's state and clock ten times a second, every chair driving a small circle,
each state stamped with the wall clock at its tick's start) and drives Debian's Chromium with
Playwright (software WebGL, as the tests). The page is made to redraw at every animation frame
(its view drifting, as while a user pans), so the frames a second measure what drawing 100 or
1,000 chairs costs, not how often a tick comes. Printed per fleet: frames a second, and the delay
from a tick's start in the "world" to the page drawing it, p50 / p99 (bus, viewer, WebSocket,
page), over the window.

Goals (issue 19): 1,000 chairs at >= 30 frames a second, p99 delay <= 100 ms.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import exit_on_sigterm, stop_all  # noqa: E402
from benchmarks.chromium import CHROMIUM, INSTALL, hooked, launch  # noqa: E402
from iw_zenoh import keys  # noqa: E402
from iw_zenoh.bus import ZenohBus  # noqa: E402
from iw_zenoh.bus.net import NetConfig, free_port, port_in_use  # noqa: E402
from iw_zenoh.messages import LabMsg, RobotSpecMsg, Tick, WorldInfo, WorldState, encode  # noqa: E402

SIM = "viewerbench"
PERIOD_S = 0.1  # ten ticks a second
GOAL_FPS, GOAL_P99_MS = 30.0, 100.0


class FakeWorld:
    """Answers ``world/info`` and publishes ``n`` chairs' state and the clock every period."""

    def __init__(self, bus: ZenohBus, n: int) -> None:
        self.bus = bus
        self.n = n
        side = math.ceil(math.sqrt(n))
        self.size = 3.0 * side + 4.0
        self.cx = np.array([2.0 + 3.0 * (i % side) + 1.5 for i in range(n)])
        self.cy = np.array([2.0 + 3.0 * (i // side) + 1.5 for i in range(n)])
        robots = [RobotSpecMsg(name=f"c{i}", id=i + 1, width_m=1.2, height_m=0.7, com=0.7) for i in range(n)]
        self.info = WorldInfo(
            revision=1,
            lab=LabMsg(name="bench", width=self.size, height=self.size),
            period_ns=int(PERIOD_S * 1e9),
            robots=robots,
            sim=SIM,
        )
        self.queries = bus.serve(keys.info(SIM))
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)

    def run(self) -> None:
        """Ticks until stopped."""
        info = encode(self.info)
        ids = [r.id for r in self.info.robots]
        tick, start = 0, time.monotonic()
        while not self.stop.is_set():
            for q in self.queries.poll():
                q.reply(info)
            tick += 1
            a = tick * PERIOD_S * 0.5  # half a radian a second round each circle
            wall = time.time_ns()
            n = self.n
            st = WorldState(
                tick=tick,
                sim_time_ns=int(tick * PERIOD_S * 1e9),
                revision=1,
                ids=ids,
                x=(self.cx + math.cos(a)).tolist(),
                y=(self.cy + math.sin(a)).tolist(),
                heading=[a + math.pi / 2] * n,
                collided=[False] * n,
                rolled_left=[0.1] * n,
                rolled_right=[0.1] * n,
                speed=[0.5] * n,
                tick_wall_ns=wall,
            )
            self.bus.publish(keys.state(SIM), encode(st))
            self.bus.publish(keys.tick(SIM), encode(Tick(tick=tick, sim_time_ns=st.sim_time_ns, period_ns=100_000_000)))
            self.stop.wait(max(0.0, start + tick * PERIOD_S - time.monotonic()))


def _start(tmp: Path, procs: list[subprocess.Popen[bytes]]) -> tuple[str, str]:
    """Starts the router and the viewer; their endpoint and the page's address."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    iwz = [sys.executable, "-m", "iw_zenoh.cli"]
    with (tmp / "router.log").open("wb") as f:
        procs.append(subprocess.Popen([*iwz, "router", "--listen", endpoint], stdout=f, stderr=subprocess.STDOUT))
    deadline = time.monotonic() + 20
    while not port_in_use(port):
        assert time.monotonic() < deadline, "the router did not listen in 20 s"
        time.sleep(0.02)
    log = tmp / "view.log"
    with log.open("wb") as f:
        argv = [*iwz, "view", "--port", "0", "--no-foxglove", "--sim", SIM, "-e", endpoint]
        procs.append(subprocess.Popen(argv, stdout=f, stderr=subprocess.STDOUT))
    while not (m := re.search(r"iwz view: (http://\S+/)", log.read_text())):
        assert procs[-1].poll() is None, f"iwz view died:\n{log.read_text()}"
        assert time.monotonic() < deadline + 40, "iwz view did not serve in time"
        time.sleep(0.05)
    return endpoint, m.group(1)


def _measure(browser: object, url: str, n: int, window_s: float) -> dict[str, float]:
    """Opens the page, waits for ``n`` chairs, then counts frames and delays over the window."""
    page = browser.new_page(viewport={"width": 1280, "height": 800})  # type: ignore[attr-defined]
    try:
        page.goto(hooked(url))
        page.wait_for_function(f"window.iwz && window.iwz.world.ids.length === {n}", timeout=60_000)
        page.evaluate("window.iwz.animate(true)")
        page.wait_for_timeout(1000)  # warm up: the page's code compiled, its canvas sized
        page.evaluate("window.iwz.resetStats()")
        before = page.evaluate("window.iwz.stats()")
        t0 = time.monotonic()
        page.wait_for_timeout(window_s * 1000)
        after = page.evaluate("window.iwz.stats()")
        elapsed = time.monotonic() - t0
    finally:
        page.close()
    fresh = after["latencies"]
    lat = np.array(fresh or [float("nan")])
    return {
        "chairs": n,
        "fps": (after["drawn"] - before["drawn"]) / elapsed,
        "delay_p50_ms": float(np.percentile(lat, 50)),
        "delay_p99_ms": float(np.percentile(lat, 99)),
        "ticks_drawn": len(fresh),
    }


def run(fleets: list[int], window_s: float) -> list[dict[str, float]]:
    """Every fleet in turn, one viewer, one browser."""
    from playwright.sync_api import sync_playwright

    procs: list[subprocess.Popen[bytes]] = []
    results: list[dict[str, float]] = []
    with tempfile.TemporaryDirectory() as d:
        try:
            endpoint, url = _start(Path(d), procs)
            with ZenohBus(NetConfig(connect=(endpoint,))) as bus, sync_playwright() as p:
                browser = launch(p)
                try:
                    for n in fleets:
                        world = FakeWorld(bus, n)
                        world.thread.start()
                        try:
                            results.append(_measure(browser, url, n, window_s))
                        finally:
                            world.stop.set()
                            world.thread.join(5)
                            world.queries.undeclare()
                finally:
                    browser.close()
        finally:
            stop_all(procs)
    return results


def main() -> int:
    """Runs the benchmark and prints its figures."""
    exit_on_sigterm()
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="3 s windows instead of 15 s")
    p.add_argument("--json", action="store_true", help="print JSON")
    args = p.parse_args()
    if not CHROMIUM.exists():
        print(f"benchmarks/viewer.py: {CHROMIUM} is missing: {INSTALL}", file=sys.stderr)
        return 2
    results = run([100, 1000], 3.0 if args.quick else 15.0)
    if args.json:
        print(json.dumps(results, indent=2))
        return 0
    print(f"{'chairs':>7} {'frames/s':>9} {'delay p50 ms':>13} {'delay p99 ms':>13} {'ticks drawn':>12}")
    for r in results:
        p50, p99 = r["delay_p50_ms"], r["delay_p99_ms"]
        print(f"{r['chairs']:>7} {r['fps']:>9.1f} {p50:>13.1f} {p99:>13.1f} {r['ticks_drawn']:>12}")
    print(f"goals: 1,000 chairs >= {GOAL_FPS:g} frames/s, p99 delay <= {GOAL_P99_MS:g} ms")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
