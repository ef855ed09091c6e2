"""A large floor crowded with chairs, shared by the benchmarks.

The hospital floor (``maps/hospital.xml``) is repeated as a grid of wings, and chairs (the LIACC
prototype: 1.04 x 0.66 m, eight 60-degree cones of 4 m) are put on free lattice points about a
metre apart, in corridors and rooms alike, without touching walls or each other.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import shapely

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.lab import Lab, Scene, tile_lab
from iw_zenoh.core.spec import RobotSpec, prototype_chair
from iw_zenoh.maps import load_lab

HOSPITAL = Path(__file__).resolve().parents[1] / "maps" / "hospital.xml"
CHAIRS_PER_WING = 100  # a wing is 40 x 20 m: one chair per 8 m^2 on average, ~1 m apart in crowds
LATTICE_M = 1.25  # centre spacing of the lattice chairs stand on


def chair(robot_id: int) -> RobotSpec:
    """The LIACC prototype chair of the seed (section 5.4.4) with 4 m cones."""
    return prototype_chair(f"c{robot_id}", id=robot_id, range_m=4.0)


def crowded_floor(n: int, seed: int = 1) -> tuple[Scene, Bodies, np.ndarray]:
    """A floor of hospital wings holding ``n`` chairs.

    Args:
        n: Number of chairs.
        seed: Seeds the choice of lattice points and headings.

    Returns:
        ``(scene, bodies, pose)`` with pose (n, 3).
    """
    wing = load_lab(HOSPITAL)
    wings = max(1, math.ceil(n / CHAIRS_PER_WING))
    cols = math.ceil(math.sqrt(wings * 2))  # wings are 2:1, so this keeps the floor squarish
    rows = math.ceil(wings / cols)
    lab: Lab = tile_lab(wing, cols, rows)
    scene = Scene(lab)
    g = np.random.default_rng(seed)
    xs = np.arange(LATTICE_M / 2 + 0.3, lab.width_m - 0.6, LATTICE_M)
    ys = np.arange(LATTICE_M / 2 + 0.3, lab.height_m - 0.6, LATTICE_M)
    pts = np.array([(x, y) for y in ys for x in xs])
    heading = g.choice([0.0, math.pi / 2, math.pi, -math.pi / 2], size=len(pts)) + g.uniform(-0.2, 0.2, len(pts))
    bodies_all = Bodies.from_specs([chair(1)] * len(pts))
    pose_all = np.column_stack([pts, heading])
    polys = shapely.polygons(bodies_all.world_outline(pose_all))
    free = ~np.isin(np.arange(len(pts)), scene.solid_tree.query(polys, predicate="intersects")[0])
    candidates = np.flatnonzero(free)
    g.shuffle(candidates)
    # greedy: keep a candidate unless it overlaps one already kept
    hits = shapely.STRtree(polys[candidates]).query(polys[candidates], predicate="intersects")
    neighbours: dict[int, list[int]] = {}
    for a, b in zip(hits[0], hits[1], strict=True):
        if a != b:
            neighbours.setdefault(int(a), []).append(int(b))
    kept: list[int] = []
    taken = np.zeros(len(candidates), dtype=bool)
    for k in range(len(candidates)):
        if taken[k]:
            continue
        kept.append(int(candidates[k]))
        taken[k] = True
        for j in neighbours.get(k, []):
            taken[j] = True
        if len(kept) == n:
            break
    if len(kept) < n:
        raise ValueError(f"only {len(kept)} free places for {n} chairs")
    pick = np.sort(np.asarray(kept))
    bodies = Bodies.from_specs([chair(i + 1) for i in range(n)])
    return scene, bodies, pose_all[pick]
