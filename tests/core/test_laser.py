from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from iw_zenoh.core import laser
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.cellgrid import scene_index
from iw_zenoh.core.lab import Lab, Scene
from iw_zenoh.core.laser import laser_distances
from iw_zenoh.core.sensors import noise_bank, read_sensors
from iw_zenoh.core.spec import LaserSpec, NoiseSpec, RobotSpec, SensorNoise
from iw_zenoh.errors import SpecError
from tests.support.builders import box_wall, random_polygon_scene, random_poses, random_scene


def reference_ranges(scene: Scene, bodies: Bodies, pose: np.ndarray) -> np.ndarray:
    """One beam at a time with plain shapely: the beam as a segment of its range, intersected
    with every wall, the border and every other body, and the distance to what is left."""
    polys = [shapely.Polygon(p) for p in bodies.world_outline(pose)]
    lz = bodies.lasers
    out = []
    for s in range(len(lz.owner)):
        i = lz.owner[s]
        x, y, th = pose[i]
        lx, ly = lz.xy[s]
        ox, oy = x + math.cos(th) * lx - math.sin(th) * ly, y + math.sin(th) * lx + math.cos(th) * ly
        origin = shapely.Point(ox, oy)
        things = [*scene.wall_polygons, scene.border, *[p for j, p in enumerate(polys) if j != i]]
        blind = any(g.geom_type == "Polygon" and g.covers(origin) for g in things)
        for j in range(lz.beams[s]):
            a = th + lz.start_rad[s] + j * lz.step_rad[s]
            r = lz.range_m[s]
            beam = shapely.LineString([(ox, oy), (ox + r * math.cos(a), oy + r * math.sin(a))])
            best = 0.0 if blind else math.inf
            for g in things:
                part = beam.intersection(g.boundary if g.geom_type == "Polygon" else g)
                if not part.is_empty:
                    best = min(best, origin.distance(part))
            out.append(best)
    return np.asarray(out)


def _random_world(
    seed: int, scene_of: Callable[[np.random.Generator], Scene] = random_scene
) -> tuple[Scene, Bodies, np.ndarray]:
    g = np.random.default_rng(seed)
    scene = scene_of(g)
    n = int(g.integers(1, 5))
    specs = []
    for i in range(n):
        lasers = tuple(
            LaserSpec(
                k,
                g.uniform(-0.5, 0.5),
                g.uniform(-0.3, 0.3),
                g.uniform(-180, 180),
                float(g.choice([g.uniform(1, 360), 360.0])),
                int(g.integers(1, 40)),
                g.uniform(0.5, 12.0),
            )
            for k in range(int(g.integers(0, 3)))
        )
        specs.append(_chair(i, g, lasers))
    return scene, Bodies.from_specs(specs), random_poses(g, n)


def _chair(i: int, g: np.random.Generator, lasers: tuple[LaserSpec, ...]) -> RobotSpec:
    if g.uniform() < 0.25:  # a disc (a Ciber-Rato body: its outline is a polygon of many sides)
        d = g.uniform(0.3, 1.2)
        return RobotSpec(f"r{i}", id=i + 1, shape="circle", width_m=d, height_m=d, lasers=lasers)  # type: ignore[arg-type]
    return RobotSpec(
        f"r{i}",
        id=i + 1,
        width_m=g.uniform(0.3, 1.5),
        height_m=g.uniform(0.3, 1.0),
        com=g.uniform(0.1, 0.9),
        lasers=lasers,
    )


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_laser_ranges_equal_an_exact_shapely_ray_cast(seed: int) -> None:
    _assert_like_shapely(*_random_world(seed))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_laser_ranges_equal_shapely_among_walls_of_any_shape_and_orientation(seed: int) -> None:
    """The kernel skips the wall edges whose wall lies towards the scanner (a beam from outside
    enters a wall before it leaves it): it must know each wall's orientation, clockwise or not,
    and a concave wall's edges, and walls overlapping one another."""
    _assert_like_shapely(*_random_world(seed, random_polygon_scene))


def _assert_like_shapely(scene: Scene, bodies: Bodies, pose: np.ndarray) -> None:
    fast = laser_distances(scene, bodies, pose)
    slow = reference_ranges(scene, bodies, pose)
    reach = np.repeat(bodies.lasers.range_m, bodies.lasers.beams)
    assert fast.shape == slow.shape
    for f, s, r in zip(fast, slow, reach, strict=True):
        if math.isinf(s) or math.isinf(f):
            assert math.isinf(s) == math.isinf(f) or min(f, s) > r - 1e-9  # only at the range limit
        else:
            assert f == pytest.approx(s, abs=1e-9)


def test_a_scanner_reads_a_wall_across_its_field_of_view() -> None:
    scene = Scene(Lab("open", 20.0, 20.0, (box_wall(12.0, 0.5, 13.0, 19.5),)))
    spec = RobotSpec("c", id=1, lasers=(LaserSpec(0, 0.5, 0.0, 0.0, 90.0, 3, 5.0),))
    d = laser_distances(scene, Bodies.from_specs([spec]), np.asarray([[10.0, 10.0, 0.0]]))
    # mounted at x = 10.5; beams at -45, 0, +45 degrees to a face at x = 12
    np.testing.assert_allclose(d, [1.5 * math.sqrt(2), 1.5, 1.5 * math.sqrt(2)], rtol=1e-12)


def test_a_scanner_sees_other_bodies_not_its_own_and_nothing_beyond_range() -> None:
    scene = Scene(Lab("open", 40.0, 20.0))
    a = RobotSpec("a", id=1, lasers=(LaserSpec(0, 0.0, 0.0, 0.0, 10.0, 2, 5.0),))
    b = RobotSpec("b", id=2)
    d = laser_distances(scene, Bodies.from_specs([a, b]), np.asarray([[10.0, 10.0, 0.0], [13.5, 10.0, 0.0]]))
    expect = 3.0 / math.cos(math.radians(5.0))  # b's rear face at x = 13, beams at +-5 degrees
    np.testing.assert_allclose(d, [expect, expect], rtol=1e-12)
    far = laser_distances(scene, Bodies.from_specs([a, b]), np.asarray([[10.0, 10.0, 0.0], [18.0, 10.0, 0.0]]))
    assert np.isinf(far).all()


def test_a_scanner_inside_a_wall_reads_zero_everywhere() -> None:
    scene = Scene(Lab("open", 20.0, 20.0, (box_wall(9.0, 9.0, 11.0, 11.0),)))
    spec = RobotSpec("c", id=1, lasers=(LaserSpec(0, beams=8, fov_deg=360.0),))
    d = laser_distances(scene, Bodies.from_specs([spec]), np.asarray([[10.0, 10.0, 0.0]]))
    np.testing.assert_array_equal(d, np.zeros(8))


def test_only_the_shards_robots_are_scanned() -> None:
    scene = Scene(Lab("open", 20.0, 20.0))
    specs = [RobotSpec(f"c{i}", id=i + 1, lasers=(LaserSpec(0, beams=4),)) for i in range(2)]
    pose = np.asarray([[5.0, 5.0, 0.0], [15.0, 15.0, 0.0]])
    b = Bodies.from_specs(specs)
    both = laser_distances(scene, b, pose)
    part = laser_distances(scene, b, pose, only=np.asarray([False, True]))
    assert np.isinf(part[:4]).all()
    np.testing.assert_array_equal(part[4:], both[4:])


def _scan(seed: int, noise: SensorNoise, *, others: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The last robot's scan read with noise, and its true ranges."""
    scene = Scene(Lab("open", 20.0, 20.0))
    specs = [RobotSpec(f"o{i}", id=10 + i) for i in range(others)]
    specs.append(RobotSpec("c", id=1, noise=noise, lasers=(LaserSpec(0, beams=32, fov_deg=360.0, range_m=30.0),)))
    b = Bodies.from_specs(specs)
    pose = np.asarray([[2.0 + 2 * i, 2.0, 0.0] for i in range(others)] + [[10.0, 10.0, 0.0]])
    r = read_sensors(
        scene,
        b,
        pose,
        collided=np.zeros(b.n, bool),
        encoder_acc=np.zeros((b.n, 2)),
        rolled_m=np.zeros((b.n, 2)),
        z=noise_bank(b, 0, seed).next(),
    )
    return r.laser_m[-32:], laser_distances(scene, b, pose)[-32:]


def test_laser_noise_is_seeded_and_reproducible_and_off_reads_the_truth() -> None:
    noisy = SensorNoise(laser_m=NoiseSpec(0.0, 0.05))
    (a, truth), (b, _), (c, _) = _scan(3, noisy), _scan(3, noisy), _scan(4, noisy)
    assert a.tolist() == b.tolist()
    assert a.tolist() != c.tolist()
    exact, _ = _scan(3, SensorNoise.off())
    np.testing.assert_array_equal(exact, truth)
    assert np.isfinite(truth).all()
    assert 0.02 < float(np.std(a - truth)) < 0.09
    # a robot's scan noise does not depend on the robots around it (its own stream)
    crowd, crowd_truth = _scan(3, noisy, others=2)
    np.testing.assert_allclose(crowd - crowd_truth, a - truth, atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"beams": 0}, "laser[0].beams"),
        ({"beams": 5000}, "laser[0].beams"),
        ({"fov_deg": 0.0}, "laser[0].fov"),
        ({"fov_deg": 361.0}, "laser[0].fov"),
        ({"range_m": -1.0}, "laser[0].range"),
        ({"range_m": float("inf")}, "laser[0].range"),
        ({"angle_deg": 190.0}, "laser[0].angle"),
    ],
)
def test_a_laser_out_of_range_is_refused_naming_its_field(kwargs: dict[str, float], field: str) -> None:
    with pytest.raises(SpecError) as e:
        LaserSpec(0, **kwargs)  # type: ignore[arg-type]
    assert e.value.field == field


def test_laser_ids_must_be_unique_on_a_robot() -> None:
    with pytest.raises(SpecError, match="laser ids"):
        RobotSpec("c", lasers=(LaserSpec(0), LaserSpec(0)))


def test_resolution_is_the_field_of_view_over_the_gaps_between_beams() -> None:
    s = LaserSpec(0, angle_deg=10.0, fov_deg=180.0, beams=181)
    assert s.resolution_deg == pytest.approx(1.0)
    assert s.start_deg == pytest.approx(-80.0)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_skipping_the_edges_a_beam_leaves_a_wall_by_reads_what_testing_every_edge_reads(seed: int) -> None:
    """The kernel skips wall edges with their wall towards the scanner; scanners anywhere, on
    walls' corners, on their edges and a hair off them (where the even-odd rule may call a point
    on the outline outside) read what the kernel testing every edge reads."""
    g = np.random.default_rng(seed)
    scene = random_polygon_scene(g)
    segs = scene.segments.reshape(-1, 4)
    on_walls = len(segs) - 4  # the border's edges come last
    pts = []
    for _ in range(30):
        a, b = segs[g.integers(max(on_walls, 1))].reshape(2, 2)
        kind = int(g.integers(4)) if on_walls else 0
        pts.append(
            (g.uniform(0.0, 10.0, 2), a, a + g.uniform() * (b - a), a + g.uniform() * (b - a) + g.normal(0, 1e-9, 2))[
                kind
            ]
        )
    xy = np.asarray(pts)
    n = len(xy)
    start, step = g.uniform(-np.pi, np.pi, n), np.full(n, np.radians(1.0))
    first = np.arange(n + 1, dtype=np.int64) * 361
    ix = scene_index(scene, np.zeros((0, 4, 2)))
    every = ix._replace(walls=ix.walls._replace(seg_side=np.zeros(len(segs))))  # no edge skipped
    args = (xy[:, 0].copy(), xy[:, 1].copy(), start, step, first, np.full(n, 20.0), np.full(n, -1, dtype=np.int64))
    np.testing.assert_array_equal(laser._scan(*args, ix), laser._scan(*args, every))
