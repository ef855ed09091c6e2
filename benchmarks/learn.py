"""Steps per second of the learning environments on one core (issue 36): ChairNav-v0 (one chair
with eight 60-degree cones and a 64-beam laser, the whole tick as the distributed roles run it),
and beside it the parts of a step: LocalWorld's tick with and without the sensors, and the
observation; and the vector environment of 256 chairs in one world, in chair-steps per second.

    python benchmarks/learn.py             # 2,000 steps each
    python benchmarks/learn.py --steps 500 --json

Targets (issue 36): a single environment >= 5,000 steps/s on one core; a batched vector env of 256
chairs >= 100,000 chair-steps/s. (ir-sim's own step, measured beside, is not in yet.)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import iw_zenoh.learn  # noqa: E402
from iw_zenoh.learn.nav import to_powers  # noqa: E402

TARGET_STEPS_S = 5000.0
TARGET_CHAIR_STEPS_S = 100_000.0
BATCH = 256  # chairs in the vector environment


def _rate(steps: int, fn: object) -> float:
    t = time.perf_counter()
    for i in range(steps):
        fn(i)  # type: ignore[operator]
    return steps / (time.perf_counter() - t)


def measure(steps: int) -> dict[str, float]:
    """Steps per second: the environment, LocalWorld's tick sensed and not, on one seeded room."""
    env = iw_zenoh.learn.ChairNavEnv(max_steps=10**9)
    env.reset(seed=1)
    g = np.random.default_rng(1)
    acts = g.uniform(-0.3, 0.3, (steps, 2)).astype(np.float32)
    acts[:, 0] = np.abs(acts[:, 0])

    def env_step(i: int) -> None:
        _, _, terminated, _, _ = env.step(acts[i])
        if terminated:
            env.reset(seed=int(i))

    out = {"env_steps_s": _rate(steps, env_step)}
    env.reset(seed=1)
    assert env.episode is not None
    world, rid, chair = env.episode.world, env.rid, env.chair
    out["world_steps_s"] = _rate(steps, lambda i: world.step({rid: to_powers(acts[i], chair, "vw")}))
    out["world_unsensed_steps_s"] = _rate(steps, lambda i: world.step({rid: (0.0, 0.0)}, sense=False))
    out["observe_s"] = _rate(steps, lambda i: env.episode.observe(rid))  # type: ignore[union-attr]
    out["target_env_steps_s"] = TARGET_STEPS_S
    venv = iw_zenoh.learn.vector_env(BATCH)
    venv.reset(seed=1)
    batch = g.uniform(-1, 1, (max(1, steps // 50), BATCH, 2)).astype(np.float32)
    out["vector_chair_steps_s"] = BATCH * _rate(len(batch), lambda i: venv.step(batch[i]))
    out["target_vector_chair_steps_s"] = TARGET_CHAIR_STEPS_S
    return out


def main() -> int:
    """Prints the figures (or JSON)."""
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--steps", type=int, default=2000, help="steps per measure (default 2000)")
    p.add_argument("--json", action="store_true", help="the figures as one JSON object")
    args = p.parse_args()
    r = measure(args.steps)
    if args.json:
        print(json.dumps(r))
        return 0
    print(f"ChairNav-v0 (8 cones, 64-beam laser), one core: {r['env_steps_s']:,.0f} steps/s (target >= 5,000)")
    print(f"  LocalWorld tick with sensors:    {r['world_steps_s']:,.0f} steps/s")
    print(f"  LocalWorld tick without sensors: {r['world_unsensed_steps_s']:,.0f} steps/s")
    print(f"  observation vector alone:        {r['observe_s']:,.0f} /s")
    print(
        f"vector env, {BATCH} chairs in one world: {r['vector_chair_steps_s']:,.0f} chair-steps/s (target >= 100,000)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
