"""Where each role spends a lock-step tick: scale.py's lock-step run, some roles under py-spy.

    python benchmarks/profile_tick.py                      # 10 one-chair agent processes, 10 s simulated
    python benchmarks/profile_tick.py --roles world sensors1 --duration 5 --top 40
    python benchmarks/profile_tick.py --roles probe0         # one agent process
    python benchmarks/profile_tick.py --chairs 100 --processes 100 --out /tmp/prof100
    python benchmarks/profile_tick.py --roles --publish-times  # no profiler: how long each publish takes

Starts the run ``benchmarks/scale.py`` measures as ``lockstep10`` (router, world, collision,
sensors, one probe agent per process) and, when the first measured state arrives, attaches the
py-spy sampling profiler to the named processes (``pip install -e '.[dev]'`` installs it; every
thread is sampled, Zenoh's callback threads included, and only while it runs Python: waiting is
left out). Start-up (imports, joining the bus, kernel compilation) is over by then and never
sampled, so the figures are per measured tick. For each profiled process it writes
``OUT/<name>.txt``, py-spy's collapsed stacks (``flamegraph.pl`` or speedscope draw them), and
prints the functions that cost most, in CPU milliseconds per tick, self and with what they call,
and each thread's CPU per tick from ``/proc`` (the Python main thread, Zenoh's ``rx``/``tx``/``app``
threads, Python callback threads), which py-spy's Python stacks do not show.

``--publish-times`` also times every publish of every process (``benchmarks/pubtimes/``): per
role and key, the calls, their mean wall time and the CPU they used. Where wall time is far
above CPU, the publishing thread waited inside Zenoh's ``put`` (its transmission thread, the
other processes on the cores): time on the tick's critical path that no Python change removes.

The profiler slows the processes it samples, so the real-time factor printed is not a figure
to quote (``scale.py`` is); compare a function's share before and after a change.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import subprocess
import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import exit_on_sigterm  # noqa: E402
from benchmarks.scale import measure_lockstep  # noqa: E402
from benchmarks.scale_run import Run  # noqa: E402

# the names scale_run.Run gives its processes (an agent process is probeK, as its --name)
ROLES = ("world", "collision", "sensors1", "probe0", "router")


def _children(pid: int) -> list[int]:
    """Child processes of ``pid`` (from /proc)."""
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def _threads(pid: int) -> dict[tuple[str, str], int]:
    """CPU clock ticks (user + system) of each thread of ``pid`` by (thread id, name), the
    process's own thread named ``main`` (Zenoh's are ``rx-0``, ``tx-0``, ``app-0``...; Python's
    others ``python``)."""
    out: dict[tuple[str, str], int] = {}
    for t in Path(f"/proc/{pid}/task").iterdir():
        try:
            name = "main" if t.name == str(pid) else (t / "comm").read_text().strip()
            fields = (t / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue  # ended meanwhile
        out[(t.name, name)] = int(fields[11]) + int(fields[12])
    return out


def thread_split(first: dict[tuple[str, str], int], last: dict[tuple[str, str], int], ticks: int) -> str:
    """CPU ms per tick of each kind of thread between two :func:`_threads` readings."""
    by: Counter[str] = Counter()
    for key, n in last.items():
        by[key[1]] += n - first.get(key, 0)
    ms = 1000 / os.sysconf("SC_CLK_TCK") / max(1, ticks)
    used = ", ".join(f"{name} {n * ms:.3f}" for name, n in by.most_common() if n)
    return used or f"none measurable (/proc counts in {ms:.3f} ms a tick here: a longer --duration)"


def profiled_run(out: Path, roles: set[str], rate: int) -> type[Run]:
    """A :class:`~benchmarks.scale.Run` that attaches py-spy to the processes named in ``roles``
    when the first measured state arrives, each writing its collapsed stacks to ``out/<name>.txt``.

    Attached then, not started under py-spy: stacks of start-up (imports, joining the bus, kernel
    compilation, registration) are never sampled, so what is divided by the ticks measured is
    what those ticks cost, the same window as ``scale.py``'s ``cpu_ms_<role>``."""

    class Profiled(Run):
        spies: list[subprocess.Popen[bytes]]
        readings: dict[str, list[dict[tuple[str, str], int]]]  # each profiled process's thread CPU

        def cpu_s(self) -> dict[str, float]:
            # measure_lockstep reads the CPU first when the first state arrives, then every 10
            # ticks: attach then, and read each thread's CPU at each of them
            for name, p in zip(self.names, self.procs, strict=True):
                if name in roles and p.poll() is None:
                    self.readings.setdefault(name, []).append(_threads(p.pid))
            if not hasattr(self, "spies"):
                self.spies = []
                spy = [str(Path(sys.executable).with_name("py-spy")), "record", "--nonblocking", "-r", str(rate)]
                for name, p in zip(self.names, self.procs, strict=True):
                    if name in roles and p.poll() is None:
                        target = ["--pid", str(p.pid), "-f", "raw", "-o", str(out / f"{name}.txt")]
                        log = (self.tmp / f"py-spy-{name}.log").open("wb")
                        self.spies.append(subprocess.Popen([*spy, *target], stdout=log, stderr=subprocess.STDOUT))
            return super().cpu_s()

        def stop(self) -> None:
            for name, got in self.readings.items():  # measured ticks: 10 a reading after the first, less one
                (out / f"{name}.threads.txt").write_text(thread_split(got[0], got[-1], 10 * (len(got) - 1) - 1))
            # py-spy writes its file when asked to stop (SIGINT) or when its target ends
            for s in getattr(self, "spies", []):
                if s.poll() is None:
                    s.send_signal(signal.SIGINT)
            for s in getattr(self, "spies", []):
                with contextlib.suppress(subprocess.TimeoutExpired):
                    s.wait(30)
            super().stop()

    Profiled.readings = {}
    return Profiled


# frames of start-up, not per-tick work: imports, compiling the module run, kernels, joining the
# bus, parsing arguments, registering. py-spy attaches once start-up is over; these leave out what
# comes late all the same (a robot registered again, a module imported on first use)
STARTUP = (
    "_find_and_load",
    "_get_module_details",
    "warm_up",
    "ZenohBus.__init__",
    "_parse (iw_zenoh/process/runtime.py",
    "AgentHost.add",
)
# leaves py-spy samples as busy while the thread waits in native code (a lock, Zenoh's own
# threads between two callbacks, which show no Python frame at all)
WAITING = ("", "Condition.wait (threading.py", "Event.wait (threading.py", "Thread.run (threading.py")


def summarise(stacks: Path, rate: int, ticks: int, top: int) -> list[str]:
    """The ``top`` functions by CPU ms per tick in py-spy's collapsed ``stacks`` file, self time
    and time with what they call; stacks of start-up, and of threads waiting, are left out."""
    self_n: Counter[str] = Counter()
    total_n: Counter[str] = Counter()
    for line in stacks.read_text().splitlines():
        stack, _, count = line.rpartition(" ")
        frames = stack.split(";")
        if any(s in stack for s in STARTUP) or frames[-1].startswith(WAITING[1:]) or not frames[-1]:
            continue
        n = int(count)
        self_n[frames[-1]] += n
        for f in set(frames):
            total_n[f] += n
    ms = 1000 / rate / max(1, ticks)
    rows = [f"{'self':>7} {'total':>7}  ms per tick"]
    for f, n in self_n.most_common(top):
        rows.append(f"{n * ms:7.3f} {total_n[f] * ms:7.3f}  {f}")
    return rows


def publish_times(folder: Path) -> list[str]:
    """Each role's publishes by key (agents summed): calls, mean wall and CPU microseconds."""
    sums: dict[tuple[str, str], list[int]] = {}
    for f in sorted(folder.glob("*.json")):
        got = json.loads(f.read_text())
        role = "agent" if got["process"].startswith("agent") else got["process"]
        for key, (n, wall, cpu) in got["keys"].items():
            s = sums.setdefault((role, key), [0, 0, 0])
            s[0], s[1], s[2] = s[0] + n, s[1] + wall, s[2] + cpu
    rows = [f"{'calls':>7} {'wall us':>8} {'cpu us':>7}  role: key"]
    for (role, key), (n, wall, cpu) in sorted(sums.items()):
        rows.append(f"{n:7d} {wall / n / 1e3:8.1f} {cpu / n / 1e3:7.1f}  {role}: {key}")
    return rows


def main(argv: list[str] | None = None) -> int:
    """Runs one profiled lock-step run and prints where its reports are."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--chairs", type=int, default=10, help="chairs (default 10)")
    ap.add_argument("--processes", type=int, default=10, help="agent processes sharing them (default 10)")
    ap.add_argument("--duration", type=float, default=10.0, help="simulated seconds (default 10: 100 ticks)")
    ap.add_argument(
        "--roles",
        nargs="*",
        default=list(ROLES[:4]),
        metavar="NAME",
        help=f"processes to profile, among {', '.join(ROLES)} (probeK, sensorsK for others); default "
        "world collision sensors1 probe0",
    )
    ap.add_argument("--publish-times", action="store_true", help="time every publish of every process")
    ap.add_argument("--rate", type=int, default=1000, help="samples a second (default 1000)")
    ap.add_argument("--top", type=int, default=25, help="functions listed for each process (default 25)")
    ap.add_argument("--out", default="/tmp/iwz-profile", metavar="DIR", help="reports and logs (default %(default)s)")
    args = ap.parse_args(argv)
    exit_on_sigterm()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.publish_times:
        times = (out / "publish").resolve()
        times.mkdir(exist_ok=True)
        for old in times.glob("*.json"):
            old.unlink()
        os.environ["IWZ_PUBLISH_TIMES_DIR"] = str(times)
        here = str(Path(__file__).resolve().parent / "pubtimes")
        os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [here, os.environ.get("PYTHONPATH")]))
    run_class = profiled_run(out.resolve(), set(args.roles), args.rate)
    res = measure_lockstep(args.chairs, args.processes, args.duration, str(out), make_run=run_class)
    ticks = int(res["ticks"])
    print(f"{ticks} ticks, {res['ms_per_tick']:.2f} ms a tick under the profiler; CPU ms per tick by role:")
    print("  " + ", ".join(f"{k[7:]} {v:.2f}" for k, v in res.items() if k.startswith("cpu_ms_")))
    for name in args.roles:
        stacks = out / f"{name}.txt"
        if not stacks.exists():
            print(f"{name}: no profile (see {out}/lockstep{args.chairs}/{name}.log)")
            continue
        print(f"{name} ({stacks}):")
        split = out / f"{name}.threads.txt"
        if split.exists():  # where py-spy cannot look: Zenoh's own threads
            print(f"  CPU ms per tick by thread: {split.read_text()}")
        print("\n".join("  " + r for r in summarise(stacks, args.rate, ticks, args.top)))
    if args.publish_times:
        print("\n".join(publish_times(out / "publish")))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
