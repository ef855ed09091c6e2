from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from iw_zenoh.core.lab import Lab, Scene
from iw_zenoh.core.legacy_ir import ciberrato_ir_distances
from tests.support.builders import box_wall

ANGLES = np.radians([0.0, 60.0, -60.0, 180.0])


def _reference(scene: Scene, pose: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Sensor by sensor with plain shapely, written from the fact sheet's words."""
    out = np.full((len(pose), len(angles)), np.inf)
    edges = shapely.MultiLineString([list(map(tuple, s)) for s in scene.segments])
    for i, (x, y, th) in enumerate(pose):
        for k, a in enumerate(angles):
            phi = th + a
            p = (x + 0.5 * math.cos(phi), y + 0.5 * math.sin(phi))
            best = math.inf
            for off in (-math.pi / 6, 0.0, math.pi / 6):
                ray = shapely.LineString([p, (p[0] + 1e4 * math.cos(phi + off), p[1] + 1e4 * math.sin(phi + off))])
                hit = ray.intersection(edges)
                if not hit.is_empty:
                    best = min(best, shapely.Point(p).distance(hit))
            for cx, cy in scene.corners:
                bearing = math.atan2(cy - p[1], cx - p[0])
                if abs((bearing - phi + math.pi) % (2 * math.pi) - math.pi) <= math.pi / 6 + 1e-12:
                    best = min(best, math.hypot(cx - p[0], cy - p[1]))
            for j, (ox, oy, _) in enumerate(pose):
                if j == i:
                    continue
                d = math.hypot(ox - p[0], oy - p[1])
                delta = abs((math.atan2(oy - p[1], ox - p[0]) - phi + math.pi) % (2 * math.pi) - math.pi)
                m = math.asin(min(1.0, 0.5 / d))
                if delta <= math.pi / 6:
                    best = min(best, d - 0.5)
                elif delta <= math.pi / 6 + m:
                    psi = delta - math.pi / 6
                    best = min(best, d * math.cos(psi) - math.sqrt(max(0.0, 0.25 - (d * math.sin(psi)) ** 2)))
            out[i, k] = best
    return out


@settings(max_examples=25)
@given(st.integers(0, 2**32 - 1))
def test_the_vectorized_legacy_ir_equals_the_sensor_by_sensor_reference(seed: int) -> None:
    g = np.random.default_rng(seed)
    walls = tuple(
        box_wall(*(xy := g.uniform(2, 24, 2)), xy[0] + g.uniform(0.2, 3), xy[1] + g.uniform(0.2, 3)) for _ in range(3)
    )
    walls = tuple(w for w in walls if max(c[0] for c in w.corners) < 28 and max(c[1] for c in w.corners) < 14)
    scene = Scene(Lab("r", 28.0, 14.0, walls))
    n = int(g.integers(1, 4))
    pose = np.column_stack([g.uniform(1, 27, n), g.uniform(1, 13, n), g.uniform(-math.pi, math.pi, n)])
    fast = ciberrato_ir_distances(scene, pose, np.tile(ANGLES, (n, 1)))
    np.testing.assert_allclose(fast, _reference(scene, pose, ANGLES), rtol=1e-9, atol=1e-9)


def test_a_wall_ahead_and_a_robot_behind() -> None:
    scene = Scene(Lab("t", 28.0, 14.0, (box_wall(10.0, 0.0, 11.0, 14.0),)))
    pose = np.array([[8.0, 7.0, 0.0], [5.0, 7.0, 0.0]])
    d = ciberrato_ir_distances(scene, pose, np.tile(ANGLES, (2, 1)))
    assert d[0, 0] == pytest.approx(1.5)  # rim at 8.5, wall at 10
    assert d[0, 3] == pytest.approx(2.0)  # the robot behind: centres 3 apart, minus two radii


def test_more_robots_than_one_vectorised_block_equal_the_reference() -> None:
    g = np.random.default_rng(7)
    scene = Scene(Lab("r", 28.0, 14.0, (box_wall(10.0, 3.0, 12.0, 9.0),)))
    n = 70  # other robots are taken 64 at a time
    pose = np.column_stack([g.uniform(1, 27, n), g.uniform(1, 13, n), g.uniform(-math.pi, math.pi, n)])
    fast = ciberrato_ir_distances(scene, pose, np.tile(ANGLES, (n, 1)))
    np.testing.assert_allclose(fast, _reference(scene, pose, ANGLES), rtol=1e-9, atol=1e-9)
