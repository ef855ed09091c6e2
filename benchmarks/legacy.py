"""The legacy bridge at its 50 ms cycle: Measures inter-arrival at the clients.

    python benchmarks/legacy.py            # 1, 20 and 100 legacy robots
    python benchmarks/legacy.py --json

Every client registers like croblink.py, answers the Measures it reads with an Actions (as agents
do; once for all it finds waiting, so the backlog of the registration phase is not answered
datagram by datagram, which flooded the bridge at the start), and timestamps every Measures.
Printed: p50 / p99 inter-arrival (ms) over all clients, and how many cycles the robots missed (a
Time skipped between a robot's first and last Measures) or received twice.

Target: every robot gets every cycle, p99 within 5 ms of the 50 ms period, at 100 robots.
(Anchor: the legacy C++ simulator keeps its 50 ms cycle up to about 40 robots, 56 ms at 50.)
"""

from __future__ import annotations

import argparse
import json
import os
import re
import selectors
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import exit_on_sigterm, stop_all  # noqa: E402
from iw_zenoh.bus.net import free_port, port_in_use  # noqa: E402

PERIOD_MS = 50.0
TARGET_P99_MS = PERIOD_MS + 5.0
TIME_RE = re.compile(rb'<Measures Time="(\d+)"')


def _lab(n: int) -> tuple[str, str]:
    cols = max(1, int(np.ceil(np.sqrt(n * 2))))
    rows = int(np.ceil(n / cols))
    w, h = cols * 3.0 + 2, rows * 3.0 + 2
    lab = f'<Lab Name="bench" Width="{w:g}" Height="{h:g}"/>'
    pos = "".join(f'<Position X="{2 + 3 * (k % cols):g}" Y="{2 + 3 * (k // cols):g}" Dir="0"/>' for k in range(n))
    return lab, f"<Grid>{pos}</Grid>"


def measure(n: int, seconds: float) -> dict[str, float]:
    """Runs n legacy robots for ``seconds``; returns inter-arrival figures."""
    with tempfile.TemporaryDirectory(prefix="iwz-legacy-") as tmp:
        t = Path(tmp)
        lab, grid = _lab(n)
        (t / "lab.xml").write_text(lab)
        (t / "grid.xml").write_text(grid)
        zport = free_port()
        ep = f"tcp/127.0.0.1:{zport}"
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.bind(("127.0.0.1", 0))
            uport = s.getsockname()[1]
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        procs = []

        def spawn(*args: str) -> None:
            log = (t / f"{args[0]}.log").open("wb")
            procs.append(
                subprocess.Popen(
                    [sys.executable, "-m", "iw_zenoh.cli", *args, "--sim", "leg"],
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    env=env,
                )
            )

        spawn("router", "--listen", ep)
        while not port_in_use(zport):
            time.sleep(0.05)
        spawn(
            "world",
            str(t / "lab.xml"),
            "--grid",
            str(t / "grid.xml"),
            "--profile",
            "ciberrato",
            "--period-ms",
            f"{PERIOD_MS:g}",
            "-e",
            ep,
        )
        spawn("collision", "-e", ep)
        spawn("sensors", "-e", ep)
        spawn("bridge", "ciberrato", "--port", str(uport), "-e", ep)
        sel = selectors.DefaultSelector()
        socks = []
        arrivals: dict[int, list[float]] = {}
        stamps: dict[int, list[int]] = {}  # the Time of each Measures received
        try:
            for k in range(n):
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                s.settimeout(2.0)
                server = None
                for _ in range(60):
                    s.sendto(f'<Robot Id="{k + 1}" Name="b{k + 1}"/>'.encode(), ("127.0.0.1", uport))
                    try:
                        _, server = s.recvfrom(1024)
                        break
                    except TimeoutError:
                        continue
                if server is None:
                    raise RuntimeError(f"robot {k + 1} got no reply")
                s.setblocking(False)
                sel.register(s, selectors.EVENT_READ, (k, server))
                socks.append(s)
                arrivals[k] = []
                stamps[k] = []
            start = time.monotonic()
            while time.monotonic() - start < seconds:
                for key, _ in sel.select(timeout=0.1):
                    k, server = key.data
                    sock = key.fileobj
                    assert isinstance(sock, socket.socket)
                    fresh = False
                    while True:
                        try:
                            data, _ = sock.recvfrom(4096)
                        except BlockingIOError:
                            break
                        if data.startswith(b"<Measures"):
                            arrivals[k].append(time.monotonic())
                            m = TIME_RE.search(data)
                            stamps[k].append(int(m.group(1)) if m else -1)
                            fresh = True
                    if fresh:  # one answer to what was read (a backlog is not answered datagram by datagram)
                        sock.sendto(b'<Actions LeftMotor="0" RightMotor="0"/>', server)
        finally:
            for s in socks:
                s.close()
            stop_all(procs)
        gaps = np.concatenate([np.diff(a[len(a) // 10 :]) for a in arrivals.values() if len(a) > 20]) * 1000
        # every cycle: each Time from a robot's first Measures to its last, exactly once
        missed = repeated = 0
        for times in stamps.values():
            times = times[len(times) // 10 :]
            if times:
                missed += (max(times) - min(times) + 1) - len(set(times))
                repeated += len(times) - len(set(times))
        return {
            "robots": n,
            "p50_ms": float(np.percentile(gaps, 50)),
            "p99_ms": float(np.percentile(gaps, 99)),
            "missed_cycles": missed,
            "repeated_cycles": repeated,
        }


def main(argv: list[str] | None = None) -> int:
    """Runs the measurements and prints them with the target."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 20, 100], help="legacy robot counts (default 1 20 100)")
    ap.add_argument("--seconds", type=float, default=20.0, help="measured seconds per size (default 20)")
    ap.add_argument("--json", action="store_true", help="one JSON object")
    args = ap.parse_args(argv)
    exit_on_sigterm()
    res = []
    for n in args.sizes:
        print(f"  measuring {n} legacy robots ...", file=sys.stderr, flush=True)
        res.append(measure(n, args.seconds))
    if args.json:
        print(
            json.dumps({"benchmark": "legacy", "period_ms": PERIOD_MS, "target_p99_ms": TARGET_P99_MS, "results": res})
        )
        return 0
    for r in res:
        print(
            f"{r['robots']:>4} robots: Measures every p50 {r['p50_ms']:.1f} ms, p99 {r['p99_ms']:.1f} ms; "
            f"cycles missed {r['missed_cycles']}, received twice {r['repeated_cycles']} (all robots together)"
        )
    print(f"target at 100 robots: every cycle, p99 <= {TARGET_P99_MS:g} ms")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
