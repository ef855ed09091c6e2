"""The distributed simulation at scale, every role its own process on this machine.

    python benchmarks/scale.py            # all four measurements (several minutes)
    python benchmarks/scale.py --json     # the same figures as one JSON object
    python benchmarks/scale.py --only lockstep10 rt100
    python benchmarks/scale.py --secure   # each figure with TLS and access control beside without, as a ratio
    python benchmarks/scale.py --secure --quick   # lockstep10 (10 s) and rt10 only: about a minute
    python benchmarks/scale.py --quick --json --only lockstep10   # a before/after check, about a minute
    python benchmarks/scale.py --secure --security acl --only lockstep10   # access control, no refusal log

Measures, on the core benchmark's floor (hospital wings, chairs about a metre apart, eight
60-degree cones of 4 m each, 100 ms ticks; every chair creeps back and forth, turning back when
something is 0.3 m ahead, so poses change every tick; ``--pushing``: they push on and collide):

* lockstep10  lock-step real-time factor with 10 agent processes (one chair each)
* lockstep100 lock-step real-time factor with 100 agent processes
* lockstep1000 lock-step real-time factor with 1,000 chairs in 4 agent-host processes
* rt100       real time, 100 chairs: p50 / p99 delay from a tick's start to its sensor message
              at an agent
* rt10        the same with 10 chairs in 2 agent processes (the quick mode's)

``--secure``: every process with its own certificate, the router enforcing the policy over mutual
TLS (docs/security.md), each figure beside the unsecured one and their ratio (goal: within 10 %).
``--security`` says how much of it, to see what each part costs: ``tls`` (mutual TLS only),
``acl`` (and the policy, the router started with ``--no-audit``), ``audit`` (and the router
logging every refusal, as ``iwz run --secure`` does; the default).

Each lock-step measurement also runs the bus floor (``benchmarks/bus_floor.py``, zenoh FIFO
receive) with as many echo processes as it has agent processes, in the same run, and gives its
real-time factor as ``floor_ratio``: the fraction of this design's physical limit on this machine
that the simulation reaches (absolute factors depend on the machine and its load; the ratio far
less). ``cpu_ms_<role>`` is each role's CPU (user + system, from /proc) per measured tick.

Targets: ratio to the floor >= 0.4 with 10 processes, >= 0.6 with 100; 1,000 chairs >= 3x;
tick-to-sensors p99 < 10 ms.
(Anchor: a ROS 2 lock-step swarm simulator runs 10 vehicles at 30x and 100 at 4x.)
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import bus_floor, chain_floor, exit_on_sigterm, scale_run, workdir  # noqa: E402

# Run is re-exported: profile_tick.py and memory.py import it from here
from benchmarks.scale_run import Run  # noqa: E402
from iw_zenoh import keys  # noqa: E402
from iw_zenoh.bus import Inbox, ZenohBus  # noqa: E402
from iw_zenoh.messages import WorldState, decode  # noqa: E402

TARGETS = {
    "lockstep10_floor_ratio": 0.4,
    "lockstep100_floor_ratio": 0.6,
    "lockstep1000_rtf": 3.0,
    "rt100_p99_ms": 10.0,
}
FLOORED = {"lockstep10": 10, "lockstep100": 100, "lockstep1000": 4}  # agent processes: the floor's echoes


def measure_lockstep(
    chairs: int,
    hosts: int,
    duration_s: float,
    logs: str | None = None,
    *,
    secure: bool = False,
    make_run: Callable[..., Run] = Run,
) -> dict[str, float]:
    """Lock-step real-time factor, from the first to the last state an observer sees."""
    with workdir(logs, f"lockstep{chairs}{'-secure' if secure else ''}", "iwz-scale-") as tmp:
        run = make_run(Path(tmp), chairs, secure=secure)
        try:
            world = run.start(lockstep=True, chairs=chairs, hosts=hosts, duration_s=duration_s)
            bus = ZenohBus(run.net("observer"))
            box = Inbox()
            bus.subscribe(keys.state("bench"), box)
            first = last = None
            ticks = 0
            warm = warm_ticks(duration_s)
            cpu0: dict[str, float] = {}
            cpu1: dict[str, float] = {}
            cpu_ticks = 0
            deadline = time.monotonic() + 600 + duration_s * 20
            while time.monotonic() < deadline:
                d = box.get(timeout_s=5)
                if d is None:
                    if world.poll() is not None:
                        break
                    continue
                ticks += 1
                if ticks <= warm:
                    continue  # warm-up, left out as the floors leave theirs out
                st = decode(d[1], WorldState)
                if first is None:
                    first = (d[2], st.tick)
                    cpu0 = run.cpu_s()
                    ticks = 1
                    warm = 0
                last = (d[2], st.tick)
                if ticks % 10 == 0:
                    cpu1 = run.cpu_s()  # the world's CPU is read before it ends the run
                    cpu_ticks = ticks - 1
            bus.close()
            if first is None or last is None or last[1] == first[1]:
                raise RuntimeError(f"no progress; see {tmp}")
            wall = (last[0] - first[0]) / 1e9
            sim = (last[1] - first[1]) * 0.1
            res: dict[str, float] = {
                "chairs": chairs,
                "agent_processes": hosts,
                "ticks": ticks,
                "rtf": sim / wall,
                "ms_per_tick": wall * 1000 / (last[1] - first[1]),
            }
            # where the two cores went: CPU ms per tick of each role (agents: all of them)
            n = max(1, cpu_ticks)
            for role in sorted(cpu1):
                res[f"cpu_ms_{role}"] = (cpu1[role] - cpu0.get(role, 0.0)) * 1000 / n
            return res
        finally:
            run.stop()


def warm_ticks(duration_s: float) -> int:
    """Ticks left out at the start of a lock-step measurement: a tenth of them, at least 10, as
    ``bus_floor.py`` and ``chain_floor.py`` leave out their warm-up rounds (the first ticks
    include processes still settling: caches, first calls of compiled kernels, late joiners)."""
    return max(10, round(duration_s / 0.1) // 10)


def measure_rt(
    chairs: int, hosts: int, duration_s: float, logs: str | None = None, *, secure: bool = False
) -> dict[str, float]:
    """Real time: delay from the world's tick start to the sensor message at an agent."""
    with workdir(logs, f"rt{chairs}{'-secure' if secure else ''}", "iwz-scale-") as tmp:
        run = Run(Path(tmp), chairs, secure=secure)
        out = str(Path(tmp) / "latency")
        try:
            world = run.start(lockstep=False, chairs=chairs, hosts=hosts, duration_s=duration_s, probe_out=out)
            world.wait(duration_s * 3 + 120)
        finally:
            run.stop()
        us: list[int] = []
        for i in range(hosts):
            p = Path(f"{out}.{i}")
            if p.exists():
                got = [int(x) for x in p.read_text().split()]  # in arrival order
                us += got[len(got) // 10 :]  # the first seconds include start-up
        if not us:
            raise RuntimeError("no latencies recorded")
        us.sort()
        return {
            "chairs": chairs,
            "agent_processes": hosts,
            "samples": len(us),
            "p50_ms": statistics.median(us) / 1000,
            "p99_ms": us[min(len(us) - 1, int(0.99 * len(us)))] / 1000,
        }


def _ratio(plain: dict[str, float], secure: dict[str, float]) -> dict[str, float]:
    """Secured over plain for each figure both have (rtf below 1, ms above 1: security's cost)."""
    wanted = ("rtf", "ms_per_tick", "p50_ms", "p99_ms", "cpu_ms_router", "cpu_ms_world")
    return {k: secure[k] / plain[k] for k in wanted if isinstance(plain.get(k), float) and plain[k] and k in secure}


def floor_rounds(processes: int, quick: bool) -> int:
    """Timed rounds of the bus floor for ``processes`` echo processes (fewer in quick mode)."""
    full = 1000 if processes <= 10 else 200
    return max(50, full // 4) if quick else full


def with_floor(res: dict[str, float], processes: int, quick: bool) -> dict[str, float]:
    """``res`` (a lock-step measurement) with the bus floor for as many processes, measured now,
    and the measured real-time factor as a ratio to it."""
    if "rtf" not in res:
        return res  # the measurement failed: nothing to compare
    floor = bus_floor.measure(processes, "fifo", floor_rounds(processes, quick))
    best = float(floor["best_rtf"])
    out = {
        **res,
        "floor_rtf": best,
        "floor_ms_per_round": float(floor["ms_per_round"]),
        "floor_ratio": res["rtf"] / best,
    }
    if res["chairs"] == processes:  # one chair a process: the chain's stand-ins are the same processes
        chain = chain_floor.measure(processes, floor_rounds(processes, quick))
        out["chain_rtf"] = float(chain["best_rtf"])
        out["chain_ms_per_tick"] = float(chain["ms_per_round"])
        out["chain_cpu_ms_per_tick"] = float(chain["cpu_ms_per_round"])
        out["chain_ratio"] = res["rtf"] / float(chain["best_rtf"])
    return out


def main(argv: list[str] | None = None) -> int:
    """Runs the measurements and prints figures with their targets."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--only",
        nargs="+",
        choices=["lockstep10", "lockstep100", "lockstep1000", "rt100", "rt10"],
        help="run these only",
    )
    ap.add_argument(
        "--secure",
        action="store_true",
        help="each measurement without, then with TLS and access control (docs/security.md), and their ratio",
    )
    ap.add_argument(
        "--security",
        choices=["tls", "acl", "audit"],
        help="implies --secure; how much of it: tls = mutual TLS only; acl = and the policy's access control "
        "(router --no-audit: refusals not logged); audit = and the router logs each refusal (the default, "
        "what iwz run --secure does)",
    )
    ap.add_argument(
        "--quick",
        action="store_true",
        help="lockstep10 for 10 s and rt10 only, a quarter of the floor's rounds (about a minute): to compare "
        "before and after a change back to back, not to quote",
    )
    ap.add_argument(
        "--no-floor", action="store_true", help="skip the bus floor (no floor_ratio): the lock-step runs only"
    )
    ap.add_argument(
        "--duration",
        type=float,
        help="simulated seconds per lock-step measurement (default: lockstep10 100, lockstep100 40, "
        "lockstep1000 10; a tenth of the ticks, at least 10, is warm-up and left out)",
    )
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument(
        "--logs",
        metavar="DIR",
        help="keep every process's log (and the map, grid, latencies) in DIR/<measurement>/",
    )
    ap.add_argument(
        "--debug", action="store_true", help="world and sensors log each tick's timings (-vv); slows them a little"
    )
    ap.add_argument(
        "--pushing",
        action="store_true",
        help="chairs creep on into whatever they meet and collide every tick (the worst case for "
        "the sensors node, which then cannot use what it computed ahead from the proposal)",
    )
    args = ap.parse_args(argv)
    exit_on_sigterm()
    scale_run.DEBUG = scale_run.DEBUG or args.debug
    scale_run.PUSHING = args.pushing
    scale_run.SECURITY = args.security or scale_run.SECURITY
    args.secure = args.secure or args.security is not None
    todo = args.only or (
        ["lockstep10", "rt10"] if args.quick else ["lockstep10", "lockstep100", "lockstep1000", "rt100"]
    )

    def duration(full: float) -> float:
        return args.duration or (min(full, 10.0) if args.quick else full)

    res: dict[str, dict[str, float]] = {}
    plans = {
        "lockstep10": lambda s: measure_lockstep(10, 10, duration(100.0), args.logs, secure=s),
        "lockstep100": lambda s: measure_lockstep(100, 100, duration(40.0), args.logs, secure=s),
        "lockstep1000": lambda s: measure_lockstep(1000, 4, duration(10.0), args.logs, secure=s),
        "rt100": lambda s: measure_rt(100, 4, 20.0, args.logs, secure=s),
        "rt10": lambda s: measure_rt(10, 2, 10.0, args.logs, secure=s),
    }
    for name in todo:
        for secure in (False, True) if args.secure else (False,):
            key = f"{name}_secure" if secure else name
            print(f"  measuring {key} ...", file=sys.stderr, flush=True)
            try:
                res[key] = plans[name](secure)
                if name in FLOORED and not secure and not args.no_floor:
                    print(f"  measuring the bus floor for {key} ...", file=sys.stderr, flush=True)
                    res[key] = with_floor(res[key], FLOORED[name], args.quick)
            except Exception as e:  # a failed measurement is reported, the others still run
                res[key] = {"error": str(e)}  # type: ignore[dict-item]
        if args.secure:
            res[f"{name}_ratio"] = _ratio(res[name], res[f"{name}_secure"])
    if args.json:
        print(json.dumps({"benchmark": "scale", "targets": TARGETS, "results": res}))
        return 0
    for name, r in res.items():
        print(f"{name:>13}: " + ", ".join(f"{k} {v:.2f}" if isinstance(v, float) else f"{k} {v}" for k, v in r.items()))
    print(
        "targets: lock-step ratio to the bus floor >= 0.4 with 10 processes, >= 0.6 with 100; "
        "1,000 chairs in 4 hosts >= 3x; real-time tick-to-sensors p99 < 10 ms"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
