"""Milliseconds per tick of the pure core: all sensors, and all collisions, on one core.

    python benchmarks/core.py            # 100, 1,000 and 10,000 chairs
    python benchmarks/core.py --json     # the same figures as one JSON object
    python benchmarks/core.py --sizes 1000 --ticks 20

Targets (issue: simulation core): for 1,000 chairs, sensors <= 30 ms and collision <= 10 ms per
tick. Anchor: a Python simulator steps 1,000 robots with 64-beam lidars in 83 ms on one core.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.floor import crowded_floor  # noqa: E402
from iw_zenoh.core.collision import check_collisions  # noqa: E402
from iw_zenoh.core.sensors import noise_bank, read_sensors  # noqa: E402
from iw_zenoh.core.world import initial_state, propose  # noqa: E402

TARGETS_MS = {"sensors_ms": 30.0, "collision_ms": 10.0}  # at 1,000 chairs


def measure(n: int, ticks: int) -> dict[str, float]:
    """Times ``ticks`` ticks of sensors and of collision for ``n`` chairs; returns medians."""
    scene, bodies, pose = crowded_floor(n)
    scene.solid_tree  # noqa: B018  (built once at start-up in the real nodes too)
    scene.segment_tree  # noqa: B018
    scene.wall_union  # noqa: B018
    bank = noise_bank(bodies, len(scene.lab.beacons), 1)
    g = np.random.default_rng(2)
    state = initial_state(pose)
    sens, coll = [], []
    for _ in range(ticks):
        cmd = g.uniform(-0.15, 0.15, (n, 2))
        state = type(state)(state.tick, state.pose, state.motor_out, cmd, state.collided, state.rolled_m)
        prop = propose(state, bodies, dt_s=0.1)
        t0 = time.perf_counter()
        col = check_collisions(scene, bodies.outline, state.pose, prop.pose)
        t1 = time.perf_counter()
        read_sensors(
            scene,
            bodies,
            state.pose,
            collided=col.collided,
            encoder_acc=np.zeros((n, 2)),
            rolled_m=prop.rolled_m,
            z=bank.next(),
        )
        t2 = time.perf_counter()
        coll.append((t1 - t0) * 1e3)
        sens.append((t2 - t1) * 1e3)
    return {
        "chairs": n,
        "cones": int(len(bodies.ir_owner)),
        "sensors_ms": statistics.median(sens),
        "sensors_ms_min": min(sens),
        "collision_ms": statistics.median(coll),
        "collision_ms_min": min(coll),
    }


def main(argv: list[str] | None = None) -> int:
    """Runs the benchmark and prints its figures and targets."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--sizes", type=int, nargs="+", default=[100, 1000, 10000], help="chair counts (default: 100 1000 10000)"
    )
    ap.add_argument("--ticks", type=int, default=10, help="ticks timed per size; the median is reported (default 10)")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    args = ap.parse_args(argv)
    rows = []
    for n in args.sizes:
        if not args.json:
            print(f"  measuring {n} chairs ...", file=sys.stderr, flush=True)
        rows.append(measure(n, args.ticks))
    if args.json:
        print(json.dumps({"benchmark": "core", "ticks": args.ticks, "targets_at_1000": TARGETS_MS, "results": rows}))
        return 0
    print(f"{'chairs':>8} {'cones':>8} {'sensors ms/tick':>22} {'collision ms/tick':>22}")
    print(f"{'':>8} {'':>8} {'median':>14} {'(min)':>7} {'median':>14} {'(min)':>7}")
    for r in rows:
        print(
            f"{r['chairs']:>8} {r['cones']:>8} {r['sensors_ms']:>14.1f} {r['sensors_ms_min']:>7.1f}"
            f" {r['collision_ms']:>14.1f} {r['collision_ms_min']:>7.1f}"
        )
    t = TARGETS_MS
    print(
        f"targets at 1,000 chairs: sensors <= {t['sensors_ms']:g} ms, collision <= {t['collision_ms']:g} ms (one core)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
