from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from iw_zenoh.core import noise
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.lab import Beacon, Lab, Scene, Target, Wall
from iw_zenoh.core.noise import NoiseBank, NoiseStreams, Stream, rng_for
from iw_zenoh.core.sensors import legacy_ir_value, noise_bank, proximity_distances, read_sensors
from iw_zenoh.core.spec import BumperSpec, IrSensorSpec, NoiseSpec, RobotSpec, SensorNoise
from tests.support.builders import box_wall, random_poses, random_scene

ARC_POINTS = 512


def reference_distances(scene: Scene, bodies: Bodies, pose: np.ndarray) -> np.ndarray:
    """One sensor at a time with plain shapely: the cone as a polygon, intersected with
    everything solid, and the distance from the mounting point to what is left."""
    polys = [shapely.Polygon(p) for p in bodies.world_outline(pose)]
    out = []
    for m in range(len(bodies.ir_owner)):
        i = bodies.ir_owner[m]
        x, y, th = pose[i]
        lx, ly = bodies.ir_xy[m]
        ox, oy = x + math.cos(th) * lx - math.sin(th) * ly, y + math.sin(th) * lx + math.cos(th) * ly
        phi, half, r = th + bodies.ir_angle_rad[m], bodies.ir_half_cone_rad[m], bodies.ir_range_m[m]
        t = np.linspace(phi - half, phi + half, ARC_POINTS)
        # the arc's chords must stay outside the true circle: scale by 1/cos(step/2)
        rr = r / math.cos((t[1] - t[0]) / 2)
        sector = shapely.Polygon([(ox, oy), *zip(ox + rr * np.cos(t), oy + rr * np.sin(t), strict=True)])
        things = [*scene.wall_polygons, scene.border, *[p for j, p in enumerate(polys) if j != i]]
        origin = shapely.Point(ox, oy)
        best = math.inf
        for g in things:
            if g.geom_type == "Polygon" and g.covers(origin):
                best = 0.0
            part = sector.intersection(g)
            if not part.is_empty:
                best = min(best, origin.distance(part))
        out.append(best if best <= r else math.inf)
    return np.asarray(out)


def _random_world(seed: int) -> tuple[Scene, Bodies, np.ndarray]:
    g = np.random.default_rng(seed)
    scene = random_scene(g)
    n = int(g.integers(1, 5))
    specs = []
    for i in range(n):
        sensors = tuple(
            IrSensorSpec(
                k,
                g.uniform(-0.5, 0.5),
                g.uniform(-0.3, 0.3),
                g.uniform(-180, 180),
                g.uniform(1, 170),
                g.uniform(0.5, 6.0),
            )
            for k in range(int(g.integers(1, 6)))
        )
        specs.append(
            RobotSpec(
                f"r{i}",
                id=i + 1,
                width_m=g.uniform(0.3, 1.5),
                height_m=g.uniform(0.3, 1.0),
                com=g.uniform(0.1, 0.9),
                ir_sensors=sensors,
            )
        )
    return scene, Bodies.from_specs(specs), random_poses(g, n)


@settings(max_examples=60)
@given(st.integers(0, 2**32 - 1))
def test_vectorized_cones_equal_the_slow_reference(seed: int) -> None:
    scene, bodies, pose = _random_world(seed)
    fast = proximity_distances(scene, bodies, pose)
    slow = reference_distances(scene, bodies, pose)
    r = bodies.ir_range_m
    for f, s, rng_m in zip(fast, slow, r, strict=True):
        if math.isinf(s) or math.isinf(f):
            # the two may only disagree about something right at the range limit
            assert math.isinf(s) == math.isinf(f) or min(f, s) > rng_m - 1e-6
        else:
            assert f == pytest.approx(s, abs=1e-6)


def test_a_wall_straight_ahead_reads_its_distance(small_scene: Scene) -> None:
    b = Bodies.from_specs([RobotSpec("c", id=1, ir_sensors=(IrSensorSpec(0, 0.5, 0.0, 0.0, 60.0, 4.0),))])
    d = proximity_distances(small_scene, b, np.array([[3.0, 2.5, 0.0]]))
    assert d[0] == pytest.approx(1.5)  # sensor at x = 3.5, pillar face at x = 5


def test_a_cone_sees_only_the_part_of_a_wall_inside_it() -> None:
    scene = Scene(Lab("lane", 20.0, 20.0, (box_wall(5.0, 11.0, 6.0, 12.0),)))

    def cone(deg: float) -> Bodies:
        return Bodies.from_specs([RobotSpec("c", id=1, ir_sensors=(IrSensorSpec(0, 0.0, 0.0, 0.0, deg, 4.0),))])

    pose = np.array([[3.5, 10.0, 0.0]])
    # half-angle 10 deg reaches y = 11 only past x = 6: the wall is beside the cone
    assert math.isinf(proximity_distances(scene, cone(20.0), pose)[0])
    # half-angle 30 deg enters the wall's lower face where its edge ray crosses y = 11
    assert proximity_distances(scene, cone(60.0), pose)[0] == pytest.approx(1.0 / math.sin(math.radians(30)))
    # half-angle 40 deg contains the nearest corner (5, 11) itself
    assert proximity_distances(scene, cone(80.0), pose)[0] == pytest.approx(math.hypot(1.5, 1.0))


def test_other_robots_are_seen_and_the_owner_is_not() -> None:
    scene = Scene(Lab("open", 20.0, 20.0))
    s = (IrSensorSpec(0, 0.0, 0.0, 0.0, 60.0, 4.0),)
    b = Bodies.from_specs([RobotSpec("a", id=1, ir_sensors=s), RobotSpec("b", id=2, ir_sensors=s)])
    d = proximity_distances(scene, b, np.array([[5.0, 10.0, 0.0], [7.0, 10.0, 0.0]]))
    assert d[0] == pytest.approx(1.5)  # b's rear face at x = 6.5
    assert math.isinf(d[1])


def test_nothing_within_range_reads_infinity_and_legacy_100() -> None:
    scene = Scene(Lab("open", 20.0, 20.0))
    b = Bodies.from_specs([RobotSpec("c", id=1, ir_sensors=(IrSensorSpec(0, 0.0, 0.0, 0.0, 30.0, 1.0),))])
    assert math.isinf(proximity_distances(scene, b, np.array([[10.0, 10.0, 0.0]]))[0])
    assert legacy_ir_value(np.array([np.inf]), np.zeros(1), np.zeros(1)).tolist() == [100.0]


def test_legacy_value_is_inverse_distance_rounded_to_a_tenth() -> None:
    d = np.array([0.5, 1.0 / 1.26, 0.005, 2.0])
    assert legacy_ir_value(d, np.zeros(4), np.zeros(4)).tolist() == [2.0, 1.3, 100.0, 0.5]


@settings(max_examples=30)
@given(seed=st.integers(0, 2**32 - 1), angle=st.floats(-math.pi, math.pi), dx=st.floats(-5, 5), dy=st.floats(-5, 5))
def test_readings_are_invariant_when_robot_and_world_move_together(
    seed: int, angle: float, dx: float, dy: float
) -> None:
    g = np.random.default_rng(seed)
    c, s = math.cos(angle), math.sin(angle)

    def move(x: float, y: float) -> tuple[float, float]:
        x, y = x - 50.0, y - 50.0
        return 50.0 + c * x - s * y + dx, 50.0 + s * x + c * y + dy

    walls = []
    for _ in range(4):
        x, y = g.uniform(46, 52, 2)
        walls.append(box_wall(x, y, x + g.uniform(0.1, 2), y + g.uniform(0.1, 2)))
    pose = np.array([[48.0, 48.0, 0.3], [49.5, 51.0, -2.0]])
    bodies = Bodies.from_specs([RobotSpec("a", id=1, width_m=1.04, height_m=0.66, com=0.81), RobotSpec("b", id=2)])
    before = proximity_distances(Scene(Lab("w", 100.0, 100.0, tuple(walls))), bodies, pose)
    moved_walls = tuple(Wall(tuple(move(*p) for p in w.corners), w.height_m) for w in walls)
    moved_pose = np.array([[*move(p[0], p[1]), p[2] + angle] for p in pose])
    after = proximity_distances(Scene(Lab("w", 100.0, 100.0, moved_walls)), bodies, moved_pose)
    np.testing.assert_allclose(after, before, atol=1e-9)


def _read(scene: Scene, specs: list[RobotSpec], pose: list[list[float]], *, seed: int = 1, rolled=None):  # type: ignore[no-untyped-def]
    b = Bodies.from_specs(specs)
    n = b.n
    return read_sensors(
        scene,
        b,
        np.asarray(pose, float),
        collided=np.zeros(n, bool),
        encoder_acc=np.zeros((n, 2)),
        rolled_m=np.zeros((n, 2)) if rolled is None else np.asarray(rolled, float),
        z=noise_bank(b, len(scene.lab.beacons), seed).next(),
    )


EXACT = SensorNoise.off()


def test_compass_and_gps_read_the_pose_without_noise() -> None:
    r = _read(Scene(Lab("open", 20.0, 20.0)), [RobotSpec("c", id=1, noise=EXACT)], [[3.0, 4.0, math.radians(100)]])
    assert r.compass_deg[0] == pytest.approx(100.0)
    np.testing.assert_allclose(r.gps[0], [3.0, 4.0, 100.0])


def test_noise_has_its_deviation_and_can_be_switched_off_per_sensor() -> None:
    scene = Scene(Lab("open", 20.0, 20.0))
    noisy = SensorNoise(compass_deg=NoiseSpec(1.0, 2.0), gps_m=NoiseSpec(0.0, 0.0, enabled=False))
    specs = [RobotSpec(f"c{i}", id=i + 1, noise=noisy) for i in range(400)]
    r = _read(scene, specs, [[10.0, 10.0, 0.0]] * 400)
    assert np.mean(r.compass_deg) == pytest.approx(1.0, abs=0.3)
    assert np.std(r.compass_deg) == pytest.approx(2.0, rel=0.15)
    np.testing.assert_array_equal(r.gps[:, 0], 10.0)


def test_readings_repeat_with_the_seed_and_not_without() -> None:
    scene = Scene(Lab("open", 20.0, 20.0, (box_wall(12, 9, 13, 11),)))
    specs = [RobotSpec("c", id=1)]
    a = _read(scene, specs, [[10.0, 10.0, 0.0]], seed=7)
    b = _read(scene, specs, [[10.0, 10.0, 0.0]], seed=7)
    c = _read(scene, specs, [[10.0, 10.0, 0.0]], seed=8)
    assert a.proximity_m.tolist() == b.proximity_m.tolist()
    assert a.compass_deg.tolist() == b.compass_deg.tolist()
    assert a.compass_deg.tolist() != c.compass_deg.tolist()


def test_a_robots_noise_does_not_depend_on_the_others() -> None:
    scene = Scene(Lab("open", 20.0, 20.0))
    alone = _read(scene, [RobotSpec("b", id=2)], [[5.0, 5.0, 0.0]])
    crowd = _read(scene, [RobotSpec("a", id=1), RobotSpec("b", id=2)], [[15.0, 15.0, 0.0], [5.0, 5.0, 0.0]])
    assert alone.compass_deg[0] == crowd.compass_deg[1]


def test_beacon_bearing_aperture_and_occlusion_by_tall_walls() -> None:
    walls = (box_wall(9.0, 4.0, 9.5, 6.0, height_m=1.0), box_wall(9.0, 14.0, 9.5, 16.0, height_m=5.0))
    lab = Lab("beacons", 20.0, 20.0, walls, (Beacon(15.0, 5.0, 2.0), Beacon(15.0, 15.0, 2.0), Beacon(5.0, 10.0, 2.0)))
    r = _read(
        Scene(lab),
        [RobotSpec("c", id=1, noise=EXACT), RobotSpec("d", id=2, noise=EXACT)],
        [[5.0, 5.0, 0.0], [5.0, 15.0, 0.0]],
    )
    assert r.beacon_deg[0, 0] == pytest.approx(0.0)  # a 1 m wall does not hide a 2 m beacon
    assert r.beacon_deg[0, 1] == pytest.approx(math.degrees(math.atan2(10, 10)))
    assert r.beacon_deg[0, 2] == pytest.approx(90.0)
    assert math.isnan(r.beacon_deg[1, 1])  # a 5 m wall does


def test_a_beacon_a_robot_carries_is_seen_where_the_robot_is_and_walls_as_tall_hide_it() -> None:
    walls = (box_wall(9.0, 14.0, 9.5, 16.0, height_m=5.0),)
    lab = Lab("carried", 20.0, 20.0, walls, (Beacon(15.0, 5.0, 2.0),))
    specs = [
        RobotSpec("carrier", id=1, noise=EXACT, beacon_height_m=2.0),
        RobotSpec("c", id=2, noise=EXACT),
        RobotSpec("d", id=3, noise=EXACT),
    ]
    pose = np.asarray([[12.0, 15.0, 0.0], [5.0, 5.0, 0.0], [5.0, 15.0, 0.0]])
    b = Bodies.from_specs(specs)
    r = read_sensors(
        Scene(lab),
        b,
        pose,
        collided=np.zeros(3, bool),
        encoder_acc=np.zeros((3, 2)),
        rolled_m=np.zeros((3, 2)),
        z=noise_bank(b, 2, 1).next(),
        moving_beacons=((0, 2.0),),
    )
    assert r.beacon_deg.shape == (3, 2)  # the lab's beacon, then the carried one
    assert r.beacon_deg[1, 0] == pytest.approx(0.0)
    assert r.beacon_deg[1, 1] == pytest.approx(math.degrees(math.atan2(10, 7)))  # where the carrier is
    assert math.isnan(r.beacon_deg[2, 1])  # the 5 m wall between them hides it
    assert math.isnan(r.beacon_deg[0, 1])  # the carrier does not see its own


def test_ground_reads_the_last_target_wholly_under_the_body() -> None:
    lab = Lab("t", 20.0, 20.0, targets=(Target(5.0, 5.0, 2.0), Target(5.5, 5.0, 2.0), Target(15.0, 15.0, 0.5)))
    r = _read(
        Scene(lab),
        [RobotSpec("c", id=1, noise=EXACT)] + [RobotSpec("d", id=2, noise=EXACT)],
        [[5.2, 5.0, 0.0], [15.0, 15.0, 0.0]],
    )
    assert r.ground.tolist() == [1, -1]  # the 1 x 1 body is larger than the 0.5-radius target


def test_ciberrato_disc_ground_rule() -> None:
    lab = Lab("t", 20.0, 20.0, targets=(Target(5.0, 5.0, 1.0),))
    disc = RobotSpec("c", id=1, shape="circle", noise=EXACT)  # type: ignore[arg-type]
    r = _read(Scene(lab), [disc, disc.placed(2, 1, 1, 0)], [[5.49, 5.0, 0.0], [5.51, 5.0, 0.0]])
    assert r.ground.tolist() == [0, -1]


def test_encoders_count_ticks_and_drift_with_slip() -> None:
    scene = Scene(Lab("open", 20.0, 20.0))
    exact = _read(scene, [RobotSpec("c", id=1, noise=EXACT)], [[5.0, 5.0, 0.0]], rolled=[[0.05, 0.1]])
    assert exact.encoder_ticks.tolist() == [[100, 200]]
    b = Bodies.from_specs([RobotSpec("c", id=1)])
    bank = noise_bank(b, 0, 3)
    acc = np.zeros((1, 2))
    for _ in range(200):
        acc = read_sensors(
            scene,
            b,
            np.array([[5.0, 5.0, 0.0]]),
            collided=np.zeros(1, bool),
            encoder_acc=acc,
            rolled_m=np.array([[0.05, 0.05]]),
            z=bank.next(),
        ).encoder_acc
    assert acc[0, 0] != acc[0, 1]  # slip makes the wheels disagree: odometry drifts
    assert acc[0, 0] == pytest.approx(200 * 0.05 * 2000, rel=0.05)


def test_bumpers_touch_walls_and_other_bodies() -> None:
    scene = Scene(Lab("b", 20.0, 20.0, (box_wall(10.55, 0.0, 11.0, 20.0),)))
    front = BumperSpec(0, ((0.5, -0.5), (0.6, -0.5), (0.6, 0.5), (0.5, 0.5)))
    specs = [RobotSpec("a", id=1, bumpers=(front,)), RobotSpec("b", id=2, bumpers=(front,)), RobotSpec("c", id=3)]
    r = _read(scene, specs, [[10.0, 5.0, 0.0], [3.0, 5.0, 0.0], [4.05, 5.0, 0.0]])
    assert r.bumpers.tolist() == [True, True]


@pytest.mark.parametrize("block", [1, 7, 32])
def test_noise_bank_gives_the_generator_sequence_whatever_the_block(block: int) -> None:
    counts = np.array([3, 0, 2])
    bank = NoiseBank([rng_for(9, i, Stream.SENSORS) for i in range(3)], counts, block=block)
    got = np.stack([bank.next() for _ in range(10)])
    expected = [rng_for(9, i, Stream.SENSORS).standard_normal((10, int(c))) for i, c in enumerate(counts)]
    np.testing.assert_array_equal(got, np.concatenate(expected, axis=1))


@given(st.lists(st.tuples(st.integers(1, 3), st.integers(0, 700)), max_size=40))
def test_noise_streams_give_each_generator_sequence_however_the_takes_are_split(
    takes: list[tuple[int, int]],
) -> None:
    streams = NoiseStreams(9, Stream.SENSORS, block=64)
    got: dict[int, list[float]] = {1: [], 2: [], 3: []}
    for rid, count in takes:
        got[rid] += streams.take(rid, count).tolist()
    for rid, values in got.items():
        assert values == rng_for(9, rid, Stream.SENSORS).standard_normal(len(values)).tolist()


@given(st.lists(st.lists(st.tuples(st.integers(0, 300), st.booleans()), min_size=3, max_size=3), max_size=30))
def test_noise_streams_fill_gives_what_take_gives(ticks: list[list[tuple[int, bool]]]) -> None:
    """fill (every robot of a tick in one call) writes the values take would have given, robot by
    robot, and leaves the skipped robots' slots and streams untouched."""
    filled, taken = NoiseStreams(9, Stream.SENSORS, block=64), NoiseStreams(9, Stream.SENSORS, block=64)
    ids = [4, 1, 7]
    for tick in ticks:
        counts = [c for c, _ in tick]
        only = [m for _, m in tick]
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(int).tolist()
        got = np.full(sum(counts), -99.0)
        filled.fill(ids, counts, starts, only, got)
        want = np.full(sum(counts), -99.0)
        for rid, c, s0, mine in zip(ids, counts, starts, only, strict=True):
            if mine:
                want[s0 : s0 + c] = taken.take(rid, c)
        assert got.tolist() == want.tolist()


_ROSTERS = (  # (ids, counts, only) a fill may be asked for, tick after tick
    ([4, 1, 7], [3, 0, 5], [True, True, True]),
    ([4, 1, 7], [3, 0, 5], [True, False, True]),
    ([1, 7], [2, 5], [True, True]),
    ([7, 4, 9], [5, 3, 1], [True, True, True]),
)


@given(
    st.lists(
        st.one_of(
            st.tuples(st.just("fill"), st.integers(0, len(_ROSTERS) - 1), st.integers(1, 9)),
            st.tuples(st.just("take"), st.sampled_from([1, 4, 7, 9]), st.integers(0, 40)),
        ),
        max_size=25,
    ),
    st.integers(1, 4),
)
def test_noise_streams_fill_drawn_ahead_gives_each_generator_sequence(
    events: list[tuple[str, int, int]], rows_max: int
) -> None:
    """fill serves a roster's ticks from rows drawn ahead; whatever the rosters, the ticks a
    roster stays, the takes between fills and the rows drawn at once, every robot's values are
    its generator's sequence, in order, and skipped slots keep what they held."""
    was = noise.ROWS_MAX
    noise.ROWS_MAX = rows_max
    try:
        streams = NoiseStreams(9, Stream.SENSORS, block=16)
        used = {rid: 0 for rid in (1, 4, 7, 9)}
        want = {rid: rng_for(9, rid, Stream.SENSORS).standard_normal(2000) for rid in used}
        for kind, a, b in events:
            if kind == "take":
                np.testing.assert_array_equal(streams.take(a, b), want[a][used[a] : used[a] + b])
                used[a] += b
                continue
            ids, counts, only = _ROSTERS[a]
            starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(int).tolist()
            for _ in range(b):
                got = np.full(sum(counts), -99.0)
                streams.fill(ids, counts, starts, only, got)
                expected = np.full(sum(counts), -99.0)
                for rid, c, s0, mine in zip(ids, counts, starts, only, strict=True):
                    if mine:
                        expected[s0 : s0 + c] = want[rid][used[rid] : used[rid] + c]
                        used[rid] += c
                np.testing.assert_array_equal(got, expected)
    finally:
        noise.ROWS_MAX = was


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 3))
def test_noise_streams_fill_on_threads_gives_each_generator_sequence(seed: int, threads: int) -> None:
    """A roster of many robots is drawn ahead in runs on threads, and its next rows on a thread
    of their own while the rows before are used: still every robot's own sequence, in order,
    after takes that left part of its block unused, a take between fills and a roster change
    (each hands back both the rows in use and the rows drawn after them)."""
    g = np.random.default_rng(seed)
    n = int(g.integers(2 * noise.THREADS_FROM * threads, 2 * noise.THREADS_FROM * threads + 30))
    ids = sorted(g.choice(1000, n, replace=False).tolist())
    counts = g.integers(0, 12, n).tolist()
    counts[: 2 * noise.THREADS_FROM * threads] = [max(c, 1) for c in counts[: 2 * noise.THREADS_FROM * threads]]
    only = (g.random(n) < 0.9).tolist()
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(int).tolist()
    was = noise.ROWS_MAX
    noise.ROWS_MAX = 3  # blocks of three ticks: the rows drawn ahead are used, not only handed back
    try:
        _fill_on_threads(g, seed, threads, ids, counts, only, starts)
    finally:
        noise.ROWS_MAX = was


def _fill_on_threads(
    g: np.random.Generator,
    seed: int,
    threads: int,
    ids: list[int],
    counts: list[int],
    only: list[bool],
    starts: list[int],
) -> None:
    n = len(ids)
    streams = NoiseStreams(seed, Stream.SENSORS, block=16, threads=threads)
    want = {rid: rng_for(seed, rid, Stream.SENSORS).standard_normal(3000) for rid in ids}
    used = dict.fromkeys(ids, 0)
    for rid in ids[::3]:
        k = int(g.integers(0, 20))
        np.testing.assert_array_equal(streams.take(rid, k), want[rid][:k])
        used[rid] = k
    for phase in range(3):  # fills, a take between them, a roster without some robots
        if phase == 1:
            rid = ids[int(g.integers(n))]
            np.testing.assert_array_equal(streams.take(rid, 5), want[rid][used[rid] : used[rid] + 5])
            used[rid] += 5
        if phase == 2:
            keep = g.random(n) < 0.8
            ids, counts, only = ([v for v, k in zip(a, keep, strict=True) if k] for a in (ids, counts, only))
            starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(int).tolist()
        for _ in range(int(g.integers(1, 60))):
            got = np.full(sum(counts), -99.0)
            streams.fill(ids, counts, starts, only, got)
            expected = np.full(sum(counts), -99.0)
            for rid, c, s0, mine in zip(ids, counts, starts, only, strict=True):
                if mine:
                    expected[s0 : s0 + c] = want[rid][used[rid] : used[rid] + c]
                    used[rid] += c
            np.testing.assert_array_equal(got, expected)
            assert streams._ahead is not None  # the next rows are being drawn on their thread


def test_a_sensor_inside_a_wall_or_another_body_reads_zero() -> None:
    scene = Scene(Lab("in", 20.0, 20.0, (box_wall(9.0, 9.0, 11.0, 11.0),)))
    s = (IrSensorSpec(0, 0.0, 0.0, 0.0, 60.0, 4.0),)
    b = Bodies.from_specs(
        [
            RobotSpec("a", id=1, ir_sensors=s),
            RobotSpec("b", id=2, ir_sensors=s),
            RobotSpec("c", id=3, width_m=3.0, height_m=3.0, ir_sensors=s),
        ]
    )
    d = proximity_distances(scene, b, np.array([[10.0, 10.0, 0.0], [3.0, 3.0, 0.0], [3.2, 3.0, 1.0]]))
    assert d[:2].tolist() == [0.0, 0.0]


@settings(max_examples=20)
@given(st.integers(0, 2**32 - 1))
def test_a_shard_reads_what_the_whole_reads_for_its_robots(seed: int) -> None:
    scene, bodies, pose = _random_world(seed)
    whole = proximity_distances(scene, bodies, pose)
    only = np.arange(bodies.n) % 2 == 0
    part = proximity_distances(scene, bodies, pose, only=only)
    mine = only[bodies.ir_owner]
    np.testing.assert_array_equal(part[mine], whole[mine])
    assert np.isinf(part[~mine]).all()
