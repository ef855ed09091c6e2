"""The sensors' kernels on numba's threads, and the cones' shared look-up, read what one cone, one
scanner, one thread at a time reads, bit for bit.

* A robot's cones look their walls and bodies up once, in the box around all of theirs
  (``cones._scan_part``); the oracle looks each cone's up in its own box (``gather``, as the
  kernel did before) and takes the same per-cone minimum (``cones._cone``).
* ``read_all(threads=2)`` (the cones and the laser beams cut into runs computed on threads) gives
  what ``threads=1`` gives, on worlds of more robots than :data:`PARALLEL_FROM`.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from iw_zenoh.core import cones
from iw_zenoh.core import read_all as read_all_module
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.cellgrid import gather, scene_index
from iw_zenoh.core.lab import Scene
from iw_zenoh.core.placing import outline_at, wedges
from iw_zenoh.core.read_all import PARALLEL_FROM, read_all
from iw_zenoh.core.sensor_noise import noise_layout
from iw_zenoh.core.spec import IrSensorSpec, LaserSpec, RobotSpec
from tests.support.builders import random_polygon_scene, random_scene


def _crowd(seed: int, n: int) -> tuple[Scene, Bodies, np.ndarray]:
    """``n`` robots with cones and lasers in a random lab, many of them close to one another."""
    g = np.random.default_rng(seed)
    scene = random_polygon_scene(g) if g.random() < 0.5 else random_scene(g)
    specs = []
    for i in range(n):
        ir = tuple(
            IrSensorSpec(k, g.uniform(-0.5, 0.5), g.uniform(-0.3, 0.3), g.uniform(-180, 180), g.uniform(1, 170), g.uniform(0.5, 6.0))
            for k in range(int(g.integers(0, 9)))
        )  # fmt: skip
        lasers = tuple(
            LaserSpec(k, g.uniform(-0.5, 0.5), g.uniform(-0.3, 0.3), g.uniform(-180, 180), g.uniform(1, 360), int(g.integers(1, 70)), g.uniform(0.5, 12.0))
            for k in range(int(g.integers(0, 2)))
        )  # fmt: skip
        specs.append(
            RobotSpec(
                f"r{i}",
                id=i + 1,
                width_m=g.uniform(0.3, 1.2),
                height_m=g.uniform(0.3, 0.9),
                ir_sensors=ir,
                lasers=lasers,
            )
        )
    pose = np.column_stack([g.uniform(0.2, 9.8, n), g.uniform(0.2, 9.8, n), g.uniform(-np.pi, np.pi, n)])
    if g.random() < 0.5:  # a huddle: bodies overlapping, mounting points inside other bodies
        pose[: n // 2, :2] = pose[0, :2] + g.normal(0.0, 0.5, (n // 2, 2))
    return scene, Bodies.from_specs(specs), pose


def _bits(a: np.ndarray) -> np.ndarray:
    return a.view(np.int64)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 30))
def test_a_robots_cones_looked_up_together_read_what_each_reads_looked_up_alone(seed: int, n: int) -> None:
    scene, bodies, pose = _crowd(seed, n)
    ix = scene_index(scene, outline_at(bodies.outline, pose))
    own = bodies.ir_owner
    ox, oy, nrm, lo, hi = wedges(
        pose, own, np.arange(len(own)), bodies.ir_xy, bodies.ir_angle_rad, bodies.ir_half_cone_rad, bodies.ir_range_m
    )
    box = np.ascontiguousarray(np.column_stack([lo, hi]))
    got = cones._scan(ox, oy, nrm, bodies.ir_range_m, box, own, ix)
    w = ix.walls
    want = np.empty(len(own))
    for i in range(len(own)):
        seen_s, near_s = np.full(len(w.segs), -1), np.empty(len(w.segs), dtype=np.int64)
        seen_b, near_b = np.full(bodies.n, -1), np.empty(bodies.n, dtype=np.int64)
        ns = gather(w.grid, w.seg_start, w.seg_items, w.seg_box, seen_s, 0, *box[i], near_s)
        nb = gather(w.grid, ix.b_start, ix.b_items, ix.bbox, seen_b, 0, *box[i], near_b)
        want[i] = cones._cone(i, ox, oy, nrm, bodies.ir_range_m, box, own, ix, near_s, ns, near_b, nb)
    np.testing.assert_array_equal(_bits(got), _bits(want))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(PARALLEL_FROM, PARALLEL_FROM + 40), st.integers(2, 5))
def test_the_sensors_on_threads_read_what_one_thread_reads(seed: int, n: int, threads: int) -> None:
    scene, bodies, pose = _crowd(seed, n)
    g = np.random.default_rng(seed + 1)
    counts, _ = noise_layout(bodies, 0)
    z = g.standard_normal(int(counts.sum()))
    acc, rolled = g.uniform(-1e3, 1e3, (n, 2)), g.uniform(-0.1, 0.1, (n, 2))
    assert read_all_module._parts(threads, n) == threads  # the parallel loop runs
    one = read_all(scene, bodies, pose, z, acc, rolled, (0.5, -0.5))
    many = read_all(scene, bodies, pose, z, acc, rolled, (0.5, -0.5), threads=threads)
    for a, b in zip(one, many, strict=True):
        np.testing.assert_array_equal(_bits(a), _bits(b))
