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
``Actions`` of the chair's agent that answers it: after a press the first moving one, after a
release the first slower one (the chair then brakes at its comfort rate, 1.2 m/s^2: the time to a
zero command is printed apart, as "release -> zero"; until 02:30 on 28 Nov the benchmark counted
that braking as latency). The world applies the newest actions at its next step (every 50 ms
here), as it does any command. Printed: p50 and p99 over every key event, and each hop's p50 /
p99: the event waiting for the page's main thread, the page's handler to its WebSocket send, the
send to the input on the bus (browser, WebSocket, ``iwz view``), the input on the bus to the
agent's actions. Then, still driving in first person, the frames the page draws a second over a
window (its 3D view's own count of drawings, and the browser's animation frames).

Goals (issue 35): latency p99 <= 60 ms; >= 30 frames a second in first person.

Measured in full (80 key events, a 10 s window) at 02:48 UTC on 28 Nov, in a calmer moment of the
shared two-core machine (load average 3 to 5, other engineers' tests running), new, old and new
code back to back:

| | new | old (commit 953bc60) | new |
|---|---|---|---|
| load average (1 min) at its start | 2.8 | 3.8 | 5.3 |
| key -> command answering it, p50 / p99 | 9.7 / 39.1 ms | 65.8 / 160.4 ms | 13.8 / 50.2 ms |
| presses p99; releases p99 | 39.6; 27.3 ms | 170.7; 147.5 ms | 56.7; 40.2 ms |
| release -> zero command (comfort braking), p50 | 39.9 ms | 89.2 ms | 51.9 ms |
| hops p50 / p99: page's main thread | 1.7 / 21.0 ms | 30.4 / 131.2 ms | 3.0 / 39.5 ms |
| viewer (browser, WebSocket, iwz view) | 3.1 / 21.8 ms | 5.8 / 56.8 ms | 4.4 / 31.6 ms |
| agent (input on the bus -> its actions) | 1.2 / 15.4 ms | 24.3 / 96.2 ms | 1.2 / 12.0 ms |
| first person: animation frames / drawings a second | 58.3 / 39.9 | 15.0 / 14.9 | 49.7 / 35.6 |

Both goals are met there (the 40 drawings a second are the view's cap while robots move). Again
at 02:57 with the final code, old then new: old (load 4.0) p50 74.9 ms, p99 153.0 ms, 13.2
frames/s, close to the lead's quiet figures for it (74.6 ms, 146.1 ms, 22.2); new (load 6.7)
p50 11.5 ms, p99 57.5 ms (page 2.9 / 34.8, viewer 4.7 / 38.0, agent 1.5 / 21.1 ms p50 / p99),
40.7 animation frames and 32.7 drawings a second.

Measured with ``--quick`` (20 key events, a 3 s window) on the shared two-core machine, the code
before (commit 953bc60) and after the latency work run back to back, alternating, three pairs,
while other engineers ran their tests (load average 8 to 25: every figure here is a loaded
machine's, its p99 set by the scheduler; the lead measured the old code on the quiet machine at
p50 74.6 ms, p99 146.1 ms, 22 drawings/s):

| | old (3 runs) | new (3 runs) |
|---|---|---|
| key -> command answering it, p50 | 113 to 156 ms | 25 to 74 ms |
| same, p99 | 369 to 740 ms | 162 to 300 ms |
| hop: key event waiting for the page's main thread, p50 | 36 to 128 ms | 2 to 13 ms |
| hop: input on the bus -> the agent's actions, p50 | 7 to 24 ms | 1 to 10 ms |
| animation frames / drawings of the 3D view a second | 2.7 to 12 / 2.4 to 11 | 22 to 48 / 16 to 40 |

Where the time went (old): the key event waited for the page's main thread, blocked by 3D frames
of 45 to 80 ms (software WebGL with 4x multisampling at full size); the viewer queued the input
behind its pump's pass; the agent applied it at its next tick (up to 50 ms) and, after a release,
the benchmark waited out the comfort braking. Now the page draws without multisampling at a
resolution its frames keep up with, carries poses on between states (drawn up to 40 a second), and
sends a moved stick at once; the viewer relays on its loop; the agent answers the input at once,
between ticks (docs/driving.md). What is left under load is the viewer hop (8 to 46 ms p50, its
p99 100 to 250 ms: the browser, the viewer's loop and the scheduler of a machine at load 20).
A quiet-machine run of the new code is still to be made; expect the chain's own cost (a few ms a
hop) plus the scheduler's.
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
from iw_zenoh.messages import Actions, DriveInput, DriveState, decode  # noqa: E402

SIM = "drivebench"
AGENT = "driven"
LAB = '<Lab Name="open" Width="30" Height="10"/>'
GOAL_P99_MS, GOAL_FPS = 60.0, 30.0
# in the page: each arrow key event's wall-clock time (ms since the epoch), in order
STAMP = """
window.__keys = [];
const stamp = (e) => {
  if (!e.repeat) window.__keys.push([performance.timeOrigin + e.timeStamp, performance.timeOrigin + performance.now()]);
};
window.addEventListener("keydown", stamp, true);
window.addEventListener("keyup", stamp, true);
window.__sent = [];
const wsSend = WebSocket.prototype.send;
WebSocket.prototype.send = function (data) {
  if (typeof data === "string" && data.includes('"cmd":"drive"')) {
    const d = JSON.parse(data).drive;
    window.__sent.push([performance.timeOrigin + performance.now(), d.seq, d.buttons]);
  }
  return wsSend.call(this, data);
};
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


class _Actions:
    """The chair's actions as they arrive at this process (wall ms), each with its wheel powers'
    size, kept in order so a key event's effect is found after it."""

    def __init__(self, rid: int) -> None:
        self.rid = rid
        self.box = Inbox()
        self.last = 0.0  # the size (|left| + |right|) of the last actions seen

    def next(self, timeout_s: float) -> tuple[float, float, float]:
        """The next actions: (arrival wall ms, its size, the size of the one before)."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            got = self.box.get(timeout_s=0.5)
            if got is None:
                continue
            a = decode(got[1], Actions)
            if a.robot_id != self.rid:
                continue
            before, self.last = self.last, abs(a.left) + abs(a.right)
            return got[2] / 1e6, self.last, before
        raise AssertionError(f"the chair's agent sent no actions within {timeout_s} s")

    def skip(self) -> None:
        """Forgets what came before (their sizes still count as the last seen)."""
        for got in self.box.drain():
            a = decode(got[1], Actions)
            if a.robot_id == self.rid:
                self.last = abs(a.left) + abs(a.right)

    def moving(self, timeout_s: float = 5.0) -> float:
        """When the first moving actions arrived."""
        while True:
            t, size, _ = self.next(timeout_s)
            if size > 1e-4:
                return t

    def slowing(self, timeout_s: float = 5.0) -> tuple[float, float]:
        """When the first actions slower than those before arrived (the command answers a release:
        the chair brakes at its comfort rate), and when the first zero ones did (it stands)."""
        slower = None
        while True:
            t, size, before = self.next(timeout_s)
            if slower is None and size < before - 1e-6:
                slower = t
            if size <= 1e-4:
                return (slower if slower is not None else t), t


def _pct(a: np.ndarray, q: float) -> float:
    """The ``q``-th percentile of ``a``, its missing values (NaN) left out."""
    return float(np.nanpercentile(a, q))


def _bus_times(box: Inbox) -> dict[int, float]:
    """The wall ms each drive input (by its seq) reached this process's subscriber."""
    return {decode(d[1], DriveInput).seq: d[2] / 1e6 for d in box.drain()}


def _sent_after(sent: list[list[float]], t: float, buttons: int) -> tuple[float, int]:
    """The first drive command the page sent at or after ``t`` with these buttons: (wall ms, seq)."""
    for when, seq, b in sent:
        if when >= t - 0.01 and int(b) == buttons:
            return when, int(seq)
    raise AssertionError(f"the page sent no drive command with buttons {buttons} after the key event")


def run(presses: int, window_s: float) -> dict[str, float]:
    """The latencies of ``presses`` press-and-release pairs, then the frame rate over ``window_s``."""
    from playwright.sync_api import sync_playwright

    procs: list[subprocess.Popen[bytes]] = []
    hops: list[dict[str, float]] = []
    with tempfile.TemporaryDirectory() as d:
        try:
            endpoint, url = _start(Path(d), procs)
            with ZenohBus(NetConfig(connect=(endpoint,))) as bus, sync_playwright() as p:
                rid = _chair(bus)
                acts = _Actions(rid)  # one robot's agent sends its actions on the robot's own key
                bus.subscribe(keys.actions(SIM, rid), acts.box)
                inputs = Inbox()  # the viewer's relay of the page's input, as the agent hears it
                bus.subscribe(keys.drive(SIM, rid), inputs)
                browser = launch(p)
                try:
                    page = browser.new_page(viewport={"width": 1280, "height": 800})
                    page.add_init_script(STAMP)
                    page.goto(f"{url}?hooks=1&drive={rid}")
                    page.wait_for_function(
                        "document.getElementById('drive-status').textContent.startsWith('you drive')", timeout=60_000
                    )
                    for k in range(presses):
                        key = "ArrowUp" if k % 2 == 0 else "ArrowDown"
                        acts.skip()
                        page.keyboard.down(key)
                        moved = acts.moving()
                        page.wait_for_timeout(150)  # it drives a little
                        acts.skip()
                        page.keyboard.up(key)
                        slowed, stood = acts.slowing()
                        (pressed, p_run), (released, r_run) = page.evaluate("window.__keys.splice(0)")[-2:]
                        sent = page.evaluate("window.__sent.splice(0)")
                        on_bus = _bus_times(inputs)
                        p_sent, p_seq = _sent_after(sent, p_run, 1)
                        r_sent, r_seq = _sent_after(sent, r_run, 0)
                        for ev, run_at, sent_at, seq, answer in (
                            ("press", p_run, p_sent, p_seq, moved),
                            ("release", r_run, r_sent, r_seq, slowed),
                        ):
                            t0 = pressed if ev == "press" else released
                            bus_at = on_bus.get(seq, float("nan"))
                            hops.append(
                                {
                                    "press": float(ev == "press"),
                                    "total": answer - t0,
                                    "page_event": run_at - t0,  # the event waits for the page's main thread
                                    "page_send": sent_at - run_at,
                                    "viewer": bus_at - sent_at,  # WebSocket, viewer, bus to this process
                                    "agent": answer - bus_at,  # the agent's answer (a tick's wait, if any)
                                    "stand": stood - t0,
                                }
                            )
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
    col = {k: np.array([h[k] for h in hops]) for k in hops[0]}
    releases = col["press"] == 0.0
    out: dict[str, float] = {
        "key_events": len(hops),
        "latency_p50_ms": _pct(col["total"], 50),
        "latency_p99_ms": _pct(col["total"], 99),
        "latency_max_ms": float(col["total"].max()),
        "press_p99_ms": _pct(col["total"][~releases], 99),
        "release_p99_ms": _pct(col["total"][releases], 99),
        "release_to_standstill_p50_ms": _pct(col["stand"][releases], 50),
        "release_to_standstill_p99_ms": _pct(col["stand"][releases], 99),
        "animation_frames_per_s": (f1 - f0) / elapsed,
        "drawn_per_s": (d1 - d0) / elapsed,
    }
    for hop in ("page_event", "page_send", "viewer", "agent"):
        out[f"{hop}_p50_ms"] = _pct(col[hop], 50)
        out[f"{hop}_p99_ms"] = _pct(col[hop], 99)
    return out


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
    print(f"key event -> the world's command answering it, over {r['key_events']} key events (20 Hz, real time):")
    print(f"  p50 {r['latency_p50_ms']:.1f} ms, p99 {r['latency_p99_ms']:.1f} ms, max {r['latency_max_ms']:.1f} ms")
    print(f"  presses p99 {r['press_p99_ms']:.1f} ms; releases p99 {r['release_p99_ms']:.1f} ms (the braking starts)")
    print(
        f"  release -> the chair's command at zero (its comfort braking included): "
        f"p50 {r['release_to_standstill_p50_ms']:.1f} ms, p99 {r['release_to_standstill_p99_ms']:.1f} ms"
    )
    print("  the hops, p50 / p99 ms:")
    for hop, what in (
        ("page_event", "key event -> the page's handler runs (its main thread busy drawing)"),
        ("page_send", "handler -> the page sends its input"),
        ("viewer", "page's send -> the input on the bus (WebSocket, viewer)"),
        ("agent", "input on the bus -> the agent's actions on the bus"),
    ):
        print(f"    {r[hop + '_p50_ms']:7.1f} / {r[hop + '_p99_ms']:7.1f}  {what}")
    print(
        f"first person while driving: {r['drawn_per_s']:.1f} drawings/s of the 3D view, "
        f"{r['animation_frames_per_s']:.1f} animation frames/s"
    )
    print(f"goals: latency p99 <= {GOAL_P99_MS:g} ms; >= {GOAL_FPS:g} frames/s in first person")
    return 0


if __name__ == "__main__":
    sys.exit(main())
