"""Memory of the distributed simulation, per role and per agent process, and whether it grows.

    python benchmarks/memory.py --quick     # 1 and 10 agent processes, start-up, a 1-minute soak
    python benchmarks/memory.py             # everything below (about 40 minutes)
    python benchmarks/memory.py --only roles10 start --json

Every role is its own process on this machine, on the scale benchmark's floor (benchmarks/scale.py);
resident memory is read from /proc/PID/status (VmRSS now, VmHWM its peak), so it is little
affected by what else the machine is doing. Measurements:

* rolesN      resident memory of the router, world, collision, sensors and each agent process,
              lock-step, N one-chair agent processes (N = 1, 10, 100), read after 50 ticks
* roles1000   the same with 1,000 chairs in 4 agent-host processes
* start       one more agent process (waypoint, then wheelchair) joining a running world: time from
              the command to its first actions (its first tick answered), and its memory then
* soak        every role's memory sampled through a run; growth = last sample over the mean of the
              samples just after warm-up (the first fifth of the run). Full: 1,000 chairs lock-step
              for 10 simulated minutes, and 100 chairs in real time for 10 wall minutes with an
              agent process leaving and another joining every 20 s. Quick: 10 chairs in real time
              for 1 minute, one agent process leaving and one joining every 10 s.

Targets (issue #23): a one-chair agent process <= 60 MB; 100 agent processes, all roles <= 6 GB;
an agent process's start to its first answered tick <= 1 s; soak growth < 5 % after warm-up.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import exit_on_sigterm  # noqa: E402
from benchmarks.floor import crowded_floor  # noqa: E402
from benchmarks.scale_run import Run  # noqa: E402
from iw_zenoh import keys  # noqa: E402
from iw_zenoh.bus import Inbox, ZenohBus  # noqa: E402
from iw_zenoh.bus.net import NetConfig  # noqa: E402
from iw_zenoh.core.geometry import wrap_deg  # noqa: E402
from iw_zenoh.messages import WorldState, decode  # noqa: E402

TARGETS = {"agent_mb": 60.0, "all_roles_100_agents_mb": 6000.0, "start_s": 1.0, "soak_growth_pct": 5.0}
SIM = "bench"  # the scale benchmark's simulation name


def memory_kb(pid: int) -> tuple[int, int]:
    """(VmRSS, VmHWM) of a process in kB; (0, 0) when it is gone."""
    try:
        text = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return 0, 0
    got = {line.split(":")[0]: int(line.split()[1]) for line in text.splitlines() if line.startswith("Vm")}
    return got.get("VmRSS", 0), got.get("VmHWM", 0)


def _role(name: str) -> str:
    return "agent" if name.startswith("agent") else name


def by_role(run: Run) -> dict[str, list[int]]:
    """Resident kB of every live process of ``run``, grouped by role."""
    out: dict[str, list[int]] = {}
    for name, p in zip(run.names, run.procs, strict=True):
        rss, _ = memory_kb(p.pid)
        if p.poll() is None and rss:
            out.setdefault(_role(name), []).append(rss)
    return out


def start_roles(run: Run, *, lockstep: bool, expect: int) -> subprocess.Popen[bytes]:
    """The router, world, collision and one sensors node of ``run``; returns the world."""
    run.start_router(30.0)
    world = ["world", str(run.lab), "--grid", str(run.grid), "--expect", str(expect)]
    if lockstep:
        world += ["--lockstep", "--lockstep-timeout-ms", "10000"]
    proc = run.spawn("world", *world)
    run.spawn("collision", "collision")
    run.spawn("sensors", "sensors")
    return proc


def spawn_probes(run: Run, name: str, count: int) -> subprocess.Popen[bytes]:
    """One agent process of ``count`` creeping probe chairs (the scale benchmark's agent)."""
    return run.spawn(f"agent-{name}", "agent", "probe", "--count", str(count), "--creep", "0.02", "--avoid", "0.3")


@contextlib.contextmanager
def running(chairs: int, *, lockstep: bool, spare: int = 0) -> Iterator[tuple[Run, Inbox]]:
    """A fresh run's roles on a floor of ``chairs + spare`` grid places (its agents are the
    caller's), and an observer of its states; every process stopped, by pid, at the end."""
    with tempfile.TemporaryDirectory(prefix="iwz-memory-") as tmp:
        run = Run(Path(tmp), chairs + spare)
        bus: ZenohBus | None = None
        try:
            start_roles(run, lockstep=lockstep, expect=chairs)
            bus = ZenohBus(NetConfig(connect=(run.endpoint,)))
            yield run, _states(bus)
        finally:
            if bus is not None:
                bus.close()
            run.stop()


def _states(bus: ZenohBus) -> Inbox:
    box = Inbox()
    bus.subscribe(keys.state(SIM), box)
    return box


def wait_ticks(box: Inbox, robots: int, ticks: int, timeout_s: float) -> None:
    """Waits for ``ticks`` states holding ``robots`` robots each."""
    deadline, seen = time.monotonic() + timeout_s, 0
    while seen < ticks:
        if time.monotonic() > deadline:
            raise RuntimeError(f"{seen} of {ticks} ticks with {robots} robots within {timeout_s:g} s")
        d = box.get(timeout_s=1.0)
        if d is not None and len(decode(d[1], WorldState).ids) >= robots:
            seen += 1


def _mb(kb: float) -> float:
    return round(kb / 1024, 1)


def measure_roles(chairs: int, hosts: int) -> dict[str, float]:
    """Resident MB per role (agents: mean and largest of one process) after 50 lock-step ticks."""
    with running(chairs, lockstep=True) as (run, states):
        per = [chairs // hosts + (1 if i < chairs % hosts else 0) for i in range(hosts)]
        for i, c in enumerate(per):
            spawn_probes(run, str(i), c)
        wait_ticks(states, chairs, 50, timeout_s=300 + chairs)
        rss = by_role(run)
    agents = rss.pop("agent", [0])
    res: dict[str, float] = {"chairs": chairs, "agent_processes": hosts}
    res.update({f"{role}_mb": _mb(sum(v)) for role, v in sorted(rss.items())})
    res["agent_mean_mb"] = _mb(sum(agents) / len(agents))
    res["agent_max_mb"] = _mb(max(agents))
    res["all_roles_mb"] = _mb(sum(agents) + sum(sum(v) for v in rss.values()))
    return res


def _joiner(run: Run, program: str, place: int, places: int) -> list[str]:
    """The command line of one more agent of ``program`` at grid place ``place`` (0-based) of
    the run's floor of ``places``."""
    x, y, heading = crowded_floor(places)[2][place]
    if program == "waypoint":
        return ["agent", "waypoint", "--waypoints", f"{x + 0.05:.3f},{y:.3f}", "--id", str(place + 1)]
    d = float(wrap_deg(math.degrees(heading)))
    return [
        "agent",
        "wheelchair",
        "--map",
        str(run.lab),
        "--start",
        f"{x:.3f},{y:.3f},{d:.1f}",
        "--goal",
        f"{x:.3f},{y:.3f}",
    ]


def measure_start(programs: tuple[str, ...] = ("waypoint", "wheelchair")) -> dict[str, float]:
    """One more agent process joining a running real-time world: seconds from its command to its
    first actions, and its resident MB (now and at its peak) a few seconds later."""
    res: dict[str, float] = {}
    with running(1, lockstep=False, spare=len(programs)) as (run, states):
        spawn_probes(run, "0", 1)
        wait_ticks(states, 1, 10, timeout_s=120)
        bus = ZenohBus(NetConfig(connect=(run.endpoint,)))
        try:
            for k, program in enumerate(programs, start=1):
                box = Inbox()
                sub = bus.subscribe(keys.all_actions(SIM), box)
                t0 = time.monotonic()
                proc = run.spawn(f"agent-{program}", *_joiner(run, program, k, 1 + len(programs)))
                first = _first_actions(box, exclude={1}, timeout_s=120, log=run.tmp / f"agent-{program}.log")
                res[f"{program}_start_s"] = round(first - t0, 2)
                time.sleep(3.0)  # a few ticks driven: what it holds at work, not at its first answer
                rss, hwm = memory_kb(proc.pid)
                res[f"{program}_mb"], res[f"{program}_peak_mb"] = _mb(rss), _mb(hwm)
                sub.undeclare()
                proc.terminate()
                proc.wait(30)
        finally:
            bus.close()
    return res


def _first_actions(box: Inbox, *, exclude: set[int], timeout_s: float, log: Path) -> float:
    """When (monotonic s) the first actions of a robot not in ``exclude`` (the probe's) arrived."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        d = box.get(timeout_s=0.5)
        if d is not None and keys.robot_id_of(d[0]) not in exclude:
            return time.monotonic()
    said = log.read_text(errors="replace").strip().splitlines()[-3:] if log.exists() else []
    raise RuntimeError(f"no actions from {log.stem} within {timeout_s:g} s; it said: {' | '.join(said)}")


def measure_soak(
    chairs: int, hosts: int, *, lockstep: bool, wall_s: float, sim_s: float = 0.0, churn_s: float = 0.0
) -> dict[str, float]:
    """Every role's resident memory through a run: per role (agents: the largest of those that ran
    throughout), MB after warm-up and at the end, and the growth between, in percent.

    Args:
        chairs: Chairs, split over ``hosts`` agent processes.
        lockstep: Lock-step, else real time.
        wall_s: How long to run (wall seconds), unless ``sim_s`` is reached first.
        sim_s: Simulated seconds to run (0: ``wall_s`` alone decides).
        churn_s: Every this many seconds one more agent process (of one chair) joins and the last
            one that joined leaves (0: none).
    """
    with running(chairs, lockstep=lockstep, spare=4 if churn_s else 0) as (run, states):
        per = [chairs // hosts + (1 if i < chairs % hosts else 0) for i in range(hosts)]
        steady = [spawn_probes(run, str(i), c) for i, c in enumerate(per)]
        wait_ticks(states, chairs, 20, timeout_s=300 + chairs)
        samples: dict[str, list[int]] = {}
        t0 = time.monotonic()
        churner: subprocess.Popen[bytes] | None = None
        joins, next_sample, next_churn, sim_now = 0, t0, t0 + churn_s, 0.0
        while time.monotonic() - t0 < wall_s and not (sim_s and sim_now >= sim_s):
            for d in states.drain():
                sim_now = decode(d[1], WorldState).sim_time_ns / 1e9
            now = time.monotonic()
            if churn_s and now >= next_churn:
                if churner is not None:
                    churner.terminate()
                joins += 1
                churner, next_churn = spawn_probes(run, f"churn{joins}", 1), now + churn_s
            if now >= next_sample:
                _sample(run, steady, samples)
                next_sample = now + max(1.0, wall_s / 60)
            time.sleep(0.2)
        _sample(run, steady, samples)
    res: dict[str, float] = {"chairs": chairs, "agent_processes": hosts, "wall_s": round(time.monotonic() - t0, 1)}
    res.update({"sim_s": round(sim_now, 1), "agents_joined_and_left": joins})
    for role, values in _growth(samples).items():
        res.update({f"{role}_{k}": v for k, v in values.items()})
    return res


def _sample(run: Run, steady: list[subprocess.Popen[bytes]], samples: dict[str, list[int]]) -> None:
    """Resident kB of every role's process and of each agent process that runs throughout."""
    for name, p in zip(run.names, run.procs, strict=True):
        if name.startswith("agent") and p not in steady:
            continue
        rss, _ = memory_kb(p.pid)
        if rss:
            samples.setdefault(name, []).append(rss)


def _growth(samples: dict[str, list[int]]) -> dict[str, dict[str, float]]:
    """Per role: MB after warm-up (the mean of the samples of the run's second fifth), at the end,
    and the growth in percent (agents: the one that grew most)."""
    out: dict[str, dict[str, float]] = {}
    for name, values in samples.items():
        n = len(values)
        warm = values[n // 5 : max(n // 5 + 1, 2 * n // 5)]
        if not warm:
            continue
        base = sum(warm) / len(warm)
        growth = round((values[-1] - base) * 100 / base, 2)
        role = _role(name)
        if role in out and out[role]["growth_pct"] >= growth:
            continue
        out[role] = {"warm_mb": _mb(base), "end_mb": _mb(values[-1]), "growth_pct": growth}
    return out


def _plans(quick: bool) -> dict[str, Callable[[], dict[str, float]]]:
    if quick:
        return {
            "roles1": lambda: measure_roles(1, 1),
            "roles10": lambda: measure_roles(10, 10),
            "start": measure_start,
            "soak": lambda: measure_soak(10, 10, lockstep=False, wall_s=60, churn_s=10),
        }
    return {
        "roles1": lambda: measure_roles(1, 1),
        "roles10": lambda: measure_roles(10, 10),
        "roles100": lambda: measure_roles(100, 100),
        "roles1000": lambda: measure_roles(1000, 4),
        "start": measure_start,
        "soak": lambda: measure_soak(1000, 4, lockstep=True, wall_s=3600, sim_s=600),
        "soak_rt": lambda: measure_soak(100, 4, lockstep=False, wall_s=600, churn_s=20),
    }


def main(argv: list[str] | None = None) -> int:
    """Runs the measurements and prints the figures with their targets."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="1 and 10 agent processes, start-up, a 1-minute soak")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="run these only (roles1 roles10 start soak ...)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    exit_on_sigterm()
    plans = _plans(args.quick)
    unknown = sorted(set(args.only or ()) - set(plans))
    if unknown:
        ap.error(f"no measurement {', '.join(unknown)} in this mode; there are: {', '.join(plans)}")
    res: dict[str, dict[str, float]] = {}
    for name in args.only or list(plans):
        print(f"  measuring {name} ...", file=sys.stderr, flush=True)
        try:
            res[name] = plans[name]()
        except Exception as e:  # a failed measurement is reported, the others still run
            res[name] = {"error": str(e)}  # type: ignore[dict-item]
    if args.json:
        print(json.dumps({"benchmark": "memory", "targets": TARGETS, "results": res}))
        return 0
    for name, r in res.items():
        print(f"{name:>9}: " + ", ".join(f"{k} {v}" for k, v in r.items()))
    print(
        "targets: a one-chair agent process <= 60 MB; 100 agent processes, all roles <= 6 GB; "
        "an agent's start to its first answered tick <= 1 s; soak growth < 5 % after warm-up"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
