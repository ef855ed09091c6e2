"""The least a lock-step tick of this design can cost: its chain of hops, with nothing computed.

    python benchmarks/chain_floor.py                  # 10 and 100 agent stand-ins
    python benchmarks/chain_floor.py --sizes 10 --rounds 2000
    python benchmarks/chain_floor.py --json

``bus_floor.py`` measures one round trip: a message out to N processes and their N answers back.
A lock-step tick of iw-zenoh is longer than that, by design (ARCHITECTURE.md: world, collision,
sensors and agents are separate processes): the world proposes, the collision process answers
with a verdict, the sensors publish one reading per chair once the verdict confirms the
proposal, each agent answers its reading with actions, and the world waits for every answer:

    world -proposed-> collision -verdict-> sensors -N readings-> N agents -N actions-> world

Here each of those is a process that does nothing but pass the message on (Python, a Zenoh
session of its own, client of an ``iwz router`` on loopback, congestion control BLOCK, zenoh's
FIFO receive: the cheapest way to receive), with payloads of the real messages' sizes
(proposal 2 KB, verdict 170 B, reading 500 B, actions 140 B; measured on the scale benchmark's
10-chair run). No physics, no collision checks, no sensing, no controller. So ``1 / round`` is
what the simulation could reach if all of its computing cost nothing: the physical limit of the
four-hop chain on this machine, against which ``scale.py`` reports ``chain_ratio``.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import zenoh  # noqa: E402

from benchmarks import exit_on_sigterm, stop_all  # noqa: E402
from benchmarks.bus_floor import cpu_s, start_router  # noqa: E402
from iw_zenoh.bus.net import NetConfig, free_port, zenoh_config  # noqa: E402

TICK_S = 0.1
PROPOSAL = b"p" * 2000
VERDICT = b"v" * 170
READING = b"r" * 500
ACTIONS = b"a" * 140
BLOCK = zenoh.CongestionControl.BLOCK
Answers = zenoh.Subscriber[zenoh.Handler[zenoh.Sample]]


def _session(endpoint: str) -> zenoh.Session:
    return zenoh.open(zenoh_config(NetConfig(connect=(endpoint,))))


def _stage(endpoint: str, role: str, n: int) -> None:
    """One stand-in process: ``collision`` answers each proposal with a verdict, ``sensors`` each
    verdict with ``n`` readings (one key per chair), ``agent<i>`` its reading with actions."""
    signal.signal(signal.SIGTERM, lambda *_: os._exit(0))
    session = _session(endpoint)
    if role == "collision":
        pub = session.declare_publisher("chain/verdict", congestion_control=BLOCK)
        sub = session.declare_subscriber("chain/proposed", zenoh.handlers.FifoChannel(256))
        while True:
            sub.recv()
            pub.put(VERDICT)
    if role == "sensors":
        pubs = [session.declare_publisher(f"chain/sensors/{i}", congestion_control=BLOCK) for i in range(n)]
        sub = session.declare_subscriber("chain/verdict", zenoh.handlers.FifoChannel(256))
        while True:
            sub.recv()
            for p in pubs:
                p.put(READING)
    i = int(role.removeprefix("agent"))
    pub = session.declare_publisher(f"chain/actions/{i}", congestion_control=BLOCK)
    sub = session.declare_subscriber(f"chain/sensors/{i}", zenoh.handlers.FifoChannel(256))
    while True:
        sub.recv()
        pub.put(ACTIONS)


def _rounds(propose: zenoh.Publisher, answers: Answers, n: int, rounds: int) -> None:
    for _ in range(rounds):
        propose.put(PROPOSAL)
        for _ in range(n):
            answers.recv()


def measure(n: int, rounds: int) -> dict[str, float | int]:
    """Rounds of the four-hop chain with ``n`` agent stand-ins."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    procs: list[subprocess.Popen[bytes]] = []
    try:
        procs.append(start_router(port))
        roles = ["collision", "sensors", *(f"agent{i}" for i in range(n))]
        procs += [subprocess.Popen([sys.executable, __file__, "--stage", endpoint, r, str(n)]) for r in roles]
        session = _session(endpoint)
        answers = session.declare_subscriber("chain/actions/*", zenoh.handlers.FifoChannel(4 * n + 64))
        propose = session.declare_publisher("chain/proposed", congestion_control=BLOCK)
        _wait_for_all(propose, answers, n)
        _rounds(propose, answers, n, max(10, rounds // 10))  # warm-up, as bus_floor.py
        cpu0 = cpu_s([p.pid for p in procs])
        t0 = time.perf_counter()
        _rounds(propose, answers, n, rounds)
        round_s = (time.perf_counter() - t0) / rounds
        cpu = cpu_s([p.pid for p in procs]) - cpu0
        session.close()  # type: ignore[no-untyped-call]
        return {
            "agents": n,
            "rounds": rounds,
            "ms_per_round": round_s * 1e3,
            "best_rtf": TICK_S / round_s,
            "cpu_ms_per_round": cpu * 1e3 / rounds,  # every stand-in and the router, the driver aside
        }
    finally:
        stop_all(procs, timeout_s=10)


def _wait_for_all(propose: zenoh.Publisher, answers: Answers, n: int) -> None:
    """Proposes until one round brings every agent's answer (each stage joins in its own time),
    then lets the stragglers of the greetings drain."""
    deadline = time.monotonic() + 120
    while True:
        if time.monotonic() > deadline:
            raise RuntimeError(f"the chain of {n} agents never answered whole")
        propose.put(PROPOSAL)
        heard: set[str] = set()
        until = time.monotonic() + 0.5
        while time.monotonic() < until and len(heard) < n:
            s = answers.try_recv()
            if s is None:
                time.sleep(0.01)  # polling: zenoh's FIFO receive has no timeout
                continue
            heard.add(str(s.key_expr))
        if len(heard) == n:
            break
    time.sleep(0.5)  # late answers to the greetings
    while answers.try_recv() is not None:
        pass


def main(argv: list[str] | None = None) -> int:
    """Runs the measurements and prints them."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[10, 100], help="agent stand-ins (default 10 100)")
    ap.add_argument("--rounds", type=int, default=0, help="timed rounds (default 1000 for 10, 200 for 100)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--stage", nargs=3, metavar=("ENDPOINT", "ROLE", "N"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    exit_on_sigterm()
    if args.stage:
        _stage(args.stage[0], args.stage[1], int(args.stage[2]))
        return 0
    res = []
    for n in args.sizes:
        print(f"  measuring the chain with {n} agents ...", file=sys.stderr, flush=True)
        res.append(measure(n, args.rounds or (1000 if n <= 10 else 200)))
    if args.json:
        print(json.dumps({"benchmark": "chain_floor", "results": res}))
        return 0
    for r in res:
        print(
            f"{r['agents']:>4} agents: {r['ms_per_round']:.2f} ms a tick "
            f"(at best {r['best_rtf']:.1f}x real time with 100 ms ticks), "
            f"{r['cpu_ms_per_round']:.2f} ms CPU a tick in all"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
