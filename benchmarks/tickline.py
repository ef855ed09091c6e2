"""Where the wall time of a lock-step tick goes: each process's steps, stamped, on one time line.

    python benchmarks/tickline.py                       # 10 one-chair agent processes, 60 s simulated
    python benchmarks/tickline.py --chairs 100 --processes 100 --duration 20
    python benchmarks/tickline.py --json > line.json

Starts the run ``benchmarks/scale.py`` measures as ``lockstep10`` with every role process stamping
its publishes, its deliveries, its loops' drains and the sensors' computing ahead
(``benchmarks/tickline_hooks/``, one clock for every process), then lines each measured tick up
from the moment the world publishes its proposal and prints, for each step, the median over the
ticks of when it happens, first and last (of the ten agents, of a robot's ten readings), in
microseconds since the tick began:

       0.0        world  P world/proposed          the world starts publishing its proposal
     188.4   +161 collision  R world/proposed      ... reaches the collision's callback thread
     218.6    +30 collision  D world/proposed      ... its loop takes it

``P``/``p`` a publish begins/returns, ``R`` a delivery reaches an inbox (Zenoh's callback thread),
``D`` a loop drains it, ``A``/``a`` the sensors begin/end computing ahead. A gap between a ``p`` of
one process and an ``R`` of another is a hop of the bus (the router, the processes' Zenoh threads,
the machine's two cores); between ``R`` and ``D`` a hand-off to a loop's thread; between ``D`` and
the next ``P`` the process's own work. The critical path of the tick is the chain of the latest
of these. The stamps cost a few microseconds each: the tick is a little longer than scale.py's
(it prints both); compare a step's place before and after a change, not the absolute tick.
The first tenth of the ticks (start-up) and the last are left out, as in ``scale.py``.
"""

from __future__ import annotations

import argparse
import bisect
import json
import os
import re
import statistics
import sys
import tempfile
from collections import defaultdict
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import exit_on_sigterm  # noqa: E402
from benchmarks.scale import measure_lockstep  # noqa: E402

Stamp = tuple[int, str, str]
ROBOT = re.compile(r"/\d+(?=/|$)")


def _kind(name: str) -> str:
    """A process's kind from its name: ``probe3`` is one of the ``agents``, ``sensors1`` the ``sensors``."""
    return "agents" if name.startswith("probe") else name.rstrip("0123456789")


def load(folder: Path) -> dict[str, list[Stamp]]:
    """Every process's stamps, by process name (``world``, ``probe3``...)."""
    out: dict[str, list[Stamp]] = {}
    for f in sorted(folder.glob("*.json")):
        out[f.stem.rsplit("-", 1)[0]] = [(int(t), s, k) for t, s, k in json.loads(f.read_text())]
    return out


def line_up(stamps: dict[str, list[Stamp]], prefix: str = "iw/bench/") -> tuple[list[dict[str, Any]], float]:
    """The median timeline of the measured ticks: one row per step (kind, stamp, key), with when it
    first and last happens in a tick (us since the world began publishing the tick's proposal),
    and the median tick (us)."""
    starts = [t for t, s, k in stamps.get("world", []) if s == "P" and k.endswith("/world/proposed")]
    if len(starts) < 12:
        raise SystemExit(f"only {len(starts)} ticks stamped: run longer (--duration)")
    first_kept = max(1, len(starts) // 10)
    per_tick: dict[int, dict[tuple[str, str, str], list[float]]] = defaultdict(dict)
    for name, own in stamps.items():
        kind = _kind(name)
        for t, s, k in own:
            i = bisect.bisect_right(starts, t) - 1
            if i < first_kept or i >= len(starts) - 1:
                continue
            step = (kind, s, ROBOT.sub("/*", k.removeprefix(prefix)))
            rel = (t - starts[i]) / 1e3
            seen = per_tick[i].setdefault(step, [rel, rel])
            seen[0], seen[1] = min(seen[0], rel), max(seen[1], rel)
    ticks = sorted(per_tick)
    steps = {step for i in ticks for step in per_tick[i]}
    rows = []
    for step in steps:
        got = [per_tick[i][step] for i in ticks if step in per_tick[i]]
        if len(got) < len(ticks) // 2:  # not a step of every tick (a registration, an event)
            continue
        rows.append(
            {
                "process": step[0],
                "stamp": step[1],
                "key": step[2],
                "first_us": statistics.median(g[0] for g in got),
                "last_us": statistics.median(g[1] for g in got),
                "ticks": len(got),
            }
        )
    rows.sort(key=lambda r: (r["first_us"], r["last_us"]))
    tick = statistics.median((starts[i + 1] - starts[i]) / 1e3 for i in ticks)
    return rows, tick


def table(rows: list[dict[str, Any]], tick_us: float) -> list[str]:
    """The timeline as lines of text, each with its gap from the line before."""
    out = [f"{'us':>8} {'gap':>6}  {'process':<9} step  key   (median over ticks; 'last' = of several)"]
    before = 0.0
    for r in rows:
        last = f"  last {r['last_us']:.0f}" if r["last_us"] - r["first_us"] >= 1 else ""
        out.append(
            f"{r['first_us']:8.1f} {r['first_us'] - before:+6.0f}  {r['process']:<9} {r['stamp']}     {r['key']}{last}"
        )
        before = r["first_us"]
    out.append(f"{tick_us:8.1f} {tick_us - before:+6.0f}  (the next tick's proposal: the median tick)")
    return out


def main(argv: list[str] | None = None) -> int:
    """Runs one stamped lock-step run and prints its tick's timeline."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--chairs", type=int, default=10, help="chairs (default 10)")
    ap.add_argument("--processes", type=int, default=10, help="agent processes sharing them (default 10)")
    ap.add_argument("--duration", type=float, default=60.0, help="simulated seconds (default 60: 600 ticks)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--out", default="", metavar="DIR", help="keep stamps and logs there (default: a temporary folder)")
    args = ap.parse_args(argv)
    exit_on_sigterm()
    with tempfile.TemporaryDirectory(prefix="iwz-tickline-") as tmp:
        out = Path(args.out or tmp)
        stamps = (out / "stamps").resolve()
        stamps.mkdir(parents=True, exist_ok=True)
        for old in stamps.glob("*.json"):
            old.unlink()
        os.environ["IWZ_TICKLINE_DIR"] = str(stamps)
        hooks = str(Path(__file__).resolve().parent / "tickline_hooks")
        os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [hooks, os.environ.get("PYTHONPATH")]))
        print(f"  a stamped lock-step run, {args.chairs} chairs in {args.processes} processes ...", file=sys.stderr)
        res = measure_lockstep(args.chairs, args.processes, args.duration, str(out))
        rows, tick = line_up(load(stamps))
    if args.json:
        print(json.dumps({"benchmark": "tickline", "run": res, "tick_us": tick, "steps": rows}))
        return 0
    print(f"{res['ticks']:.0f} ticks measured, {res['ms_per_tick'] * 1e3:.0f} us a tick (stamped; median {tick:.0f})")
    print("\n".join(table(rows, tick)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
