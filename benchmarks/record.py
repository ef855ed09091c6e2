"""The recorder and replay at load.

    python benchmarks/record.py           # all figures
    python benchmarks/record.py --json    # one JSON object

* sustained: a publisher process sends small messages on 20 keys as fast as it can for a while;
  the recorder (its own process) records them; received == published is checked per key, and the
  rate is what got through with zero loss.
* size per simulated minute for 100 chairs: a synthetic minute of 100-chair traffic (state,
  proposed, verdict, tick, sensors and actions of every chair at 10 Hz) written by the recorder
  core, zstd chunks.
* seek: a synthetic one-hour recording (10 Hz states); the time from asking for simulation time T
  to holding the first state at or after T, for random T.

Targets: >= 20,000 messages/s with zero loss; seek < 1 s anywhere in an hour.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402
from mcap.reader import make_reader  # noqa: E402

from benchmarks import exit_on_sigterm  # noqa: E402
from iw_zenoh import keys  # noqa: E402
from iw_zenoh.bus import Inbox, ZenohBus  # noqa: E402
from iw_zenoh.bus.net import NetConfig, free_port, port_in_use  # noqa: E402
from iw_zenoh.messages import Actions, SensorReading, WorldState, encode  # noqa: E402
from iw_zenoh.record.recording import Recorder  # noqa: E402
from iw_zenoh.record.replay import sim_index  # noqa: E402

TARGETS = {"sustained_msgs_per_s": 20000, "seek_s": 1.0}
TICK = 100_000_000


def sustained(seconds: float) -> dict[str, float]:
    """Publish flat out for ``seconds``; return the rate and whether every key's count matched."""
    with tempfile.TemporaryDirectory(prefix="iwz-rec-") as tmp:
        port = free_port()
        ep = f"tcp/127.0.0.1:{port}"
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        router = subprocess.Popen(
            [sys.executable, "-m", "iw_zenoh.cli", "router", "--sim", "b", "--listen", ep],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.STDOUT,
        )
        while not port_in_use(port):
            time.sleep(0.05)
        out = Path(tmp) / "load.mcap"
        rec = subprocess.Popen(
            [sys.executable, "-m", "iw_zenoh.cli", "record", "-o", str(out), "--quiet", "--sim", "b", "-e", ep],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.STDOUT,
        )
        try:
            bus = ZenohBus(NetConfig(connect=(ep,)))
            up = Inbox()
            import threading

            alive = threading.Event()
            bus.watch_alive(keys.alive("b", "recorder", "recorder"), lambda _k, a: alive.set() if a else None)
            alive.wait(30)
            topics = [keys.actions("b", i) for i in range(1, 21)]
            payload = encode(Actions(robot_id=1, left=0.1, right=0.1))
            sent = dict.fromkeys(topics, 0)
            start = time.monotonic()
            while time.monotonic() - start < seconds:
                for k in topics:
                    bus.publish(k, payload)
                    sent[k] += 1
            # our last message's round trip: everything before it has left this session
            bus.subscribe(keys.event("b", "mark"), up)
            bus.publish(keys.event("b", "mark"), b'{"kind":"mark"}')
            up.get(timeout_s=60)
            elapsed = time.monotonic() - start
            bus.close()
            rec.send_signal(signal.SIGINT)
            rec.wait(120)
            with out.open("rb") as f:
                counts = {m.name: m.metadata for m in make_reader(f).iter_metadata()}["iw.counts"]
            lost = sum(sent[k] - int(counts.get(k, 0)) for k in topics)  # the mark is not counted
            total = sum(sent.values())
            return {"messages": total, "seconds": elapsed, "msgs_per_s": total / elapsed, "lost": lost}
        finally:
            for p in (rec, router):
                if p.poll() is None:
                    p.kill()
                    p.wait(5)


def _state(t: int, n: int) -> bytes:
    xs = [float(i) for i in range(n)]
    return encode(
        WorldState(
            tick=t,
            sim_time_ns=t * TICK,
            revision=1,
            ids=list(range(1, n + 1)),
            x=xs,
            y=xs,
            heading=xs,
            collided=[False] * n,
            rolled_left=xs,
            rolled_right=xs,
            speed=xs,
        )
    )


def size_per_minute(chairs: int = 100) -> dict[str, float]:
    """Bytes of one simulated minute of a 100-chair run (10 Hz), as recorded."""
    g = np.random.default_rng(1)
    with tempfile.TemporaryFile() as f:
        rec = Recorder(f)
        for t in range(1, 601):
            log = t * TICK
            st = _state(t, chairs)
            for k in (keys.state("s"), keys.proposed("s"), keys.verdict("s"), keys.tick("s")):
                rec.add(k, st, log)
            for rid in range(1, chairs + 1):
                prox = [float(v) for v in g.uniform(0.3, 4.0, 8)]
                r = SensorReading(
                    tick=t,
                    sim_time_ns=t * TICK,
                    robot_id=rid,
                    proximity_ids=list(range(8)),
                    proximity_m=list[float | None](prox),
                    proximity_legacy=[round(1 / v, 1) for v in prox],
                    compass_deg=float(g.uniform(-180, 180)),
                    gps=(1.0, 2.0, 3.0),
                    encoders=(t * 10, t * 11),
                )
                rec.add(keys.sensors("s", rid), encode(r), log + 1)
                rec.add(keys.actions("s", rid), encode(Actions(tick=t, robot_id=rid, left=0.1, right=0.09)), log + 2)
        rec.finish()
        return {"chairs": chairs, "mb_per_sim_minute": f.tell() / 1e6}


def seek(hours: float = 1.0, samples: int = 20) -> dict[str, float]:
    """Seconds to reach a random simulation time in an hour-long recording."""
    with tempfile.TemporaryDirectory(prefix="iwz-seek-") as tmp:
        path = Path(tmp) / "hour.mcap"
        ticks = int(hours * 36000)
        with path.open("wb") as f:
            rec = Recorder(f)
            for t in range(1, ticks + 1):
                rec.add(keys.state("s"), _state(t, 10), t * TICK)
            rec.finish()
        g = np.random.default_rng(2)
        times = []
        for target in g.integers(0, ticks * TICK, samples):
            t0 = time.perf_counter()
            with path.open("rb") as f:
                sims, logs, _ = sim_index(f)
                import bisect

                i = max(0, bisect.bisect_right(sims, int(target)) - 1)
                f.seek(0)
                for _, _, m in make_reader(f).iter_messages(starting_at=logs[i] if logs else None):
                    if m.publish_time >= target:
                        break
            times.append(time.perf_counter() - t0)
        return {
            "hours": hours,
            "size_mb": path.stat().st_size / 1e6,
            "seek_p50_s": statistics.median(times),
            "seek_max_s": max(times),
        }


def main(argv: list[str] | None = None) -> int:
    """Runs the measurements and prints figures with their targets."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--seconds", type=float, default=30.0, help="duration of the sustained-load measurement (default 30)"
    )
    ap.add_argument("--json", action="store_true", help="one JSON object")
    args = ap.parse_args(argv)
    exit_on_sigterm()
    res: dict[str, dict[str, float]] = {}
    measures: tuple[tuple[str, Callable[[], dict[str, float]]], ...] = (
        ("sustained", lambda: sustained(args.seconds)),
        ("size", size_per_minute),
        ("seek", seek),
    )
    for name, fn in measures:
        print(f"  measuring {name} ...", file=sys.stderr, flush=True)
        res[name] = fn()
    if args.json:
        print(json.dumps({"benchmark": "record", "targets": TARGETS, "results": res}))
        return 0
    s, z, k = res["sustained"], res["size"], res["seek"]
    print(
        f"sustained: {s['msgs_per_s']:.0f} messages/s for {s['seconds']:.0f} s, {s['lost']} lost "
        "(target >= 20,000/s, none lost)"
    )
    print(f"size: {z['mb_per_sim_minute']:.1f} MB per simulated minute for {z['chairs']} chairs")
    print(
        f"seek in a {k['hours']:g} h recording ({k['size_mb']:.0f} MB): p50 {k['seek_p50_s'] * 1000:.0f} ms, "
        f"max {k['seek_max_s'] * 1000:.0f} ms (target < 1 s)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
