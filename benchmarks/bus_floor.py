"""The least a lock-step round can cost on this machine: the bus alone, with no simulation.

    python benchmarks/bus_floor.py                 # 10 and 100 echo processes, both ways of receiving
    python benchmarks/bus_floor.py --sizes 10 --rounds 2000
    python benchmarks/bus_floor.py --json

A driver publishes one message; N echo processes (Python, each its own Zenoh session, clients
of an ``iwz router`` on loopback, congestion control BLOCK: the configuration of every iw-zenoh
process) each answer with one message; the driver waits for all N answers, then starts the
next round. Nothing is computed. Two ways of receiving are measured:

* ``bus``: :class:`iw_zenoh.bus.ZenohBus` as every node uses it (a Zenoh callback puts the
  message in an inbox and wakes the node's loop);
* ``fifo``: zenoh-python's own FIFO channel, the loop blocking in ``recv()`` (no Python
  callback).

A lock-step tick of iw-zenoh makes this round trip once to the agents and back, plus the world's
hops to the collision and sensors processes, plus the work; so ``1 / round`` bounds the real-time
factor ``scale.py`` can measure with N agent processes; its targets are ratios to this floor
(>= 0.4 with 10 processes, >= 0.6 with 100). ``chain_floor.py`` measures the tick's own chain.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import zenoh  # noqa: E402

from benchmarks import exit_on_sigterm, stop_all  # noqa: E402
from iw_zenoh.bus import Inbox, ZenohBus  # noqa: E402
from iw_zenoh.bus.net import NetConfig, free_port, port_in_use, zenoh_config  # noqa: E402

TICK_S = 0.1
PAYLOAD = b"x" * 500  # about one chair's sensor reading


def _echo(endpoint: str, index: int, how: str) -> None:
    """One echo process: answers every message on ``floor/ask`` on ``floor/answer/<index>``."""
    signal.signal(signal.SIGTERM, lambda *_: os._exit(0))
    if how == "bus":
        bus = ZenohBus(NetConfig(connect=(endpoint,)))
        wake = threading.Event()
        box = Inbox(wake=wake)
        bus.subscribe("floor/ask", box)
        key = f"floor/answer/{index}"
        while True:
            wake.wait()
            wake.clear()
            for _, data, _ in box.drain():
                bus.publish(key, data)
    session = zenoh.open(zenoh_config(NetConfig(connect=(endpoint,))))
    pub = session.declare_publisher(f"floor/answer/{index}", congestion_control=zenoh.CongestionControl.BLOCK)
    sub = session.declare_subscriber("floor/ask", zenoh.handlers.FifoChannel(256))
    while True:
        pub.put(sub.recv().payload.to_bytes())


def cpu_s(pids: list[int]) -> float:
    """CPU seconds (user + system, from /proc) the processes ``pids`` have used so far."""
    tick = os.sysconf("SC_CLK_TCK")
    total = 0
    for pid in pids:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        total += int(fields[11]) + int(fields[12])
    return total / tick


def start_router(port: int) -> subprocess.Popen[bytes]:
    """An ``iwz router`` on ``tcp/127.0.0.1:port``, once its port takes connections."""
    p = subprocess.Popen(
        [sys.executable, "-m", "iw_zenoh.cli", "router", "--listen", f"tcp/127.0.0.1:{port}"],
        stdout=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 20
    while not port_in_use(port):
        if time.monotonic() > deadline:
            p.kill()
            raise RuntimeError("the router did not start")
        time.sleep(0.05)  # polling the port: the router tells nothing when it listens
    return p


def measure(n: int, how: str, rounds: int) -> dict[str, float | int | str]:
    """Rounds of one message out to ``n`` echo processes and ``n`` answers back."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    procs: list[subprocess.Popen[bytes]] = []
    try:
        procs.append(start_router(port))
        echoes = [subprocess.Popen([sys.executable, __file__, "--echo", endpoint, str(i), how]) for i in range(n)]
        procs += echoes
        session = zenoh.open(zenoh_config(NetConfig(connect=(endpoint,))))
        answers = session.declare_subscriber("floor/answer/*", zenoh.handlers.FifoChannel(4 * n + 64))
        ask = session.declare_publisher("floor/ask", congestion_control=zenoh.CongestionControl.BLOCK)
        # wait until every echo answers (each joins in its own time)
        heard: set[str] = set()
        deadline = time.monotonic() + 120
        while len(heard) < n:
            if time.monotonic() > deadline:
                raise RuntimeError(f"only {len(heard)} of {n} echo processes answered")
            ask.put(b"hello")
            until = time.monotonic() + 0.3
            while time.monotonic() < until:
                s = answers.try_recv()
                if s is None:
                    time.sleep(0.01)
                    continue
                heard.add(str(s.key_expr))
        time.sleep(0.5)  # late answers to the greetings
        while answers.try_recv() is not None:
            pass
        warm = max(10, rounds // 10)
        for _ in range(warm):
            ask.put(PAYLOAD)
            for _ in range(n):
                answers.recv()
        cpu0 = cpu_s([p.pid for p in echoes])
        t0 = time.perf_counter()
        for _ in range(rounds):
            ask.put(PAYLOAD)
            for _ in range(n):
                answers.recv()
        round_s = (time.perf_counter() - t0) / rounds
        cpu = cpu_s([p.pid for p in echoes]) - cpu0
        session.close()  # type: ignore[no-untyped-call]
        return {
            "echo_processes": n,
            "receive": how,
            "rounds": rounds,
            "ms_per_round": round_s * 1e3,
            "best_rtf": TICK_S / round_s,
            "echo_cpu_ms_per_round": cpu * 1e3 / rounds / n,
        }
    finally:
        stop_all(procs, timeout_s=10)


def main(argv: list[str] | None = None) -> int:
    """Runs the measurements and prints them."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[10, 100], help="echo processes (default 10 100)")
    ap.add_argument("--receive", nargs="+", choices=["bus", "fifo"], default=["bus", "fifo"])
    ap.add_argument("--rounds", type=int, default=0, help="timed rounds (default 1000 for 10, 200 for 100)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--echo", nargs=3, metavar=("ENDPOINT", "INDEX", "RECEIVE"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    exit_on_sigterm()
    if args.echo:
        _echo(args.echo[0], int(args.echo[1]), args.echo[2])
        return 0
    res = []
    for n in args.sizes:
        for how in args.receive:
            print(f"  measuring {n} echo processes, {how} ...", file=sys.stderr, flush=True)
            res.append(measure(n, how, args.rounds or (1000 if n <= 10 else 200)))
    if args.json:
        print(json.dumps({"benchmark": "bus_floor", "results": res}))
        return 0
    for r in res:
        print(
            f"{r['echo_processes']:>4} echo processes, {r['receive']:>4}: {r['ms_per_round']:.2f} ms a round "
            f"(at best {r['best_rtf']:.1f}x real time with 100 ms ticks), "
            f"{r['echo_cpu_ms_per_round']:.3f} ms CPU per echo per round"
        )
    print("scale.py targets: its lock-step factor >= 0.4 of this floor with 10 processes, >= 0.6 with 100")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
