"""Milliseconds per tick of the pure core: all sensors, and all collisions, on one core; and,
beside it, the proximity cones alone and a 64-beam laser scanner on every chair.

    python benchmarks/core.py            # 100, 1,000 and 10,000 chairs
    python benchmarks/core.py --quick    # 100 and 1,000 chairs, 3 ticks: a quick look
    python benchmarks/core.py --json     # the same figures as one JSON object
    python benchmarks/core.py --sizes 1000 --ticks 20

Targets (issue: simulation core): for 1,000 chairs, sensors <= 30 ms and collision <= 10 ms per
tick; 1,000 chairs each with a 64-beam laser scanner <= 40 ms (issue 21). Anchor: a Python
simulator steps 1,000 robots with 64-beam lidars in 83 ms on one core.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.floor import chair, crowded_floor  # noqa: E402
from iw_zenoh.core.bodies import Bodies  # noqa: E402
from iw_zenoh.core.collision import check_collisions  # noqa: E402
from iw_zenoh.core.laser import laser_distances  # noqa: E402
from iw_zenoh.core.sensors import noise_bank, proximity_distances, read_sensors  # noqa: E402
from iw_zenoh.core.spec import LaserSpec  # noqa: E402
from iw_zenoh.core.world import initial_state, propose  # noqa: E402

TARGETS_MS = {"sensors_ms": 30.0, "collision_ms": 10.0, "laser_ms": 40.0}  # at 1,000 chairs
SCANNER = LaserSpec(0, 0.6, 0.0, 0.0, 270.0, 64, 10.0)  # 64 beams over 270 degrees, 10 m, at the front


def measure_scanners(n: int, ticks: int) -> dict[str, float]:
    """Times the proximity cones alone and a 64-beam scanner on every chair (medians, ms)."""
    scene, bodies, pose = crowded_floor(n)
    with_laser = Bodies.from_specs([replace(chair(int(i)), lasers=(SCANNER,)) for i in bodies.ids])
    cones, laser = [], []
    g = np.random.default_rng(3)
    for _ in range(ticks):
        p = pose + g.uniform(-0.02, 0.02, pose.shape)  # chairs move a little between ticks
        t0 = time.perf_counter()
        proximity_distances(scene, bodies, p)
        t1 = time.perf_counter()
        laser_distances(scene, with_laser, p)
        t2 = time.perf_counter()
        cones.append((t1 - t0) * 1e3)
        laser.append((t2 - t1) * 1e3)
    return {"cones_ms": statistics.median(cones), "laser_ms": statistics.median(laser), "beams": n * SCANNER.beams}


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
    ap.add_argument("--quick", action="store_true", help="100 and 1,000 chairs, 3 ticks each")
    args = ap.parse_args(argv)
    if args.quick:
        args.sizes, args.ticks = [100, 1000], 3
    rows = []
    for n in args.sizes:
        if not args.json:
            print(f"  measuring {n} chairs ...", file=sys.stderr, flush=True)
        measure_scanners(min(n, 100), 1)  # compiles (or loads) the kernels outside the timing
        rows.append(measure(n, args.ticks) | measure_scanners(n, args.ticks))
    if args.json:
        print(json.dumps({"benchmark": "core", "ticks": args.ticks, "targets_at_1000": TARGETS_MS, "results": rows}))
        return 0
    print(
        f"{'chairs':>8} {'cones':>8} {'sensors ms/tick':>22} {'collision ms/tick':>22}"
        f" {'cones alone':>12} {'64-beam laser':>14}"
    )
    print(f"{'':>8} {'':>8} {'median':>14} {'(min)':>7} {'median':>14} {'(min)':>7} {'median':>12} {'median':>14}")
    for r in rows:
        print(
            f"{r['chairs']:>8} {r['cones']:>8} {r['sensors_ms']:>14.1f} {r['sensors_ms_min']:>7.1f}"
            f" {r['collision_ms']:>14.1f} {r['collision_ms_min']:>7.1f} {r['cones_ms']:>12.1f} {r['laser_ms']:>14.1f}"
        )
    t = TARGETS_MS
    print(
        f"targets at 1,000 chairs: sensors <= {t['sensors_ms']:g} ms, collision <= {t['collision_ms']:g} ms,"
        f" a 64-beam laser on every chair <= {t['laser_ms']:g} ms (one core)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
