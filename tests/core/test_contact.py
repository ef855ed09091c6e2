"""The compiled contact kernel against the rule written plainly with shapely (GEOS)."""

from __future__ import annotations

import math

import numpy as np
import shapely
from hypothesis import assume, example, given
from hypothesis import strategies as st

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.collision import interpolate_pose
from iw_zenoh.core.contact import TOUCH_M, touching
from iw_zenoh.core.geometry import to_world
from iw_zenoh.core.lab import Lab, Scene, Wall
from iw_zenoh.core.spec import BodyShape, RobotSpec

W, H = 8.0, 6.0
pose = st.tuples(st.floats(0.0, W), st.floats(0.0, H), st.floats(-math.pi, math.pi))
step = st.tuples(st.floats(-0.8, 0.8), st.floats(-0.8, 0.8), st.floats(-1.0, 1.0))
point = st.tuples(st.floats(0.5, W - 0.5), st.floats(0.5, H - 0.5))


@st.composite
def walls(draw: st.DrawFn) -> Wall:
    """A simple polygon of 3-6 corners, convex or not (a star around a centre)."""
    cx, cy = draw(point)
    k = draw(st.integers(3, 6))
    radii = draw(st.lists(st.floats(0.05, 1.5), min_size=k, max_size=k))
    start = draw(st.floats(0.0, 2 * math.pi))
    corners = tuple(
        (cx + r * math.cos(start + 2 * math.pi * i / k), cy + r * math.sin(start + 2 * math.pi * i / k))
        for i, r in enumerate(radii)
    )
    return Wall(corners, 1.0)


def _reference(
    scene: Scene, c_now: np.ndarray, c_mid: np.ndarray, c_next: np.ndarray, free: np.ndarray
) -> tuple[set[tuple[int, int]], set[tuple[int, int]], float]:
    """The rule with GEOS predicates on every pair, and the smallest gap between any two
    geometries the rule compares (near TOUCH_M the kernel may say touch where GEOS does not)."""
    now, mid, nxt = (shapely.polygons(c) for c in (c_now, c_mid, c_next))
    hull = [
        shapely.convex_hull(shapely.multipoints(np.concatenate([a, b, c])))
        for a, b, c in zip(c_now, c_mid, c_next, strict=True)
    ]
    gaps = [math.inf]

    def meets(a: shapely.Geometry, b: shapely.Geometry) -> bool:
        with np.errstate(all="ignore"):  # GEOS warns on degenerate hulls (a point); the gap is then nan
            d = shapely.distance(a, b)
        if d > 0.0:
            gaps.append(d)
        return bool(shapely.intersects(a, b))

    wall_hits: set[tuple[int, int]] = set()
    nw = len(scene.lab.walls)
    for i in range(len(c_now)):
        if free[i]:
            continue
        for w, wp in enumerate(scene.wall_polygons):
            if meets(nxt[i], wp) or (meets(hull[i], wp) and not meets(now[i], wp)):
                wall_hits.add((i, w))
        x, y = c_next[i, :, 0], c_next[i, :, 1]
        if x.min() < 0 or y.min() < 0 or x.max() > W or y.max() > H:
            wall_hits.add((i, nw))
    robot_hits = {
        (i, j)
        for i in range(len(c_now))
        for j in range(i + 1, len(c_now))
        if meets(nxt[i], nxt[j]) or (meets(mid[i], mid[j]) and not meets(now[i], now[j]))
    }
    return wall_hits, robot_hits, min(gaps)


@example(  # a body that does not move: its swept hull is its outline; GEOS warned in the reference
    lab_walls=[
        Wall(((3.0, 1.0), (1.5000000000000002, 1.8660254037844388), (1.4999999999999996, 0.13397459621556163)), 1.0)
    ],
    now=[(0.0, 0.0, 5.1078033254986546e-226)],
    moves=[(0.0, 0.0, 0.0)] * 5,
    free=[False] * 5,
    circle=False,
)
@given(
    lab_walls=st.lists(walls(), max_size=3),
    now=st.lists(pose, min_size=1, max_size=5),
    moves=st.lists(step, min_size=5, max_size=5),
    free=st.lists(st.booleans(), min_size=5, max_size=5),
    circle=st.booleans(),
)
def test_kernel_gives_what_geos_gives(lab_walls, now, moves, free, circle) -> None:  # type: ignore[no-untyped-def]
    scene = Scene(Lab("t", W, H, tuple(lab_walls)))
    n = len(now)
    shape = dict(shape=BodyShape.CIRCLE, width_m=0.8, height_m=0.8) if circle else dict(width_m=1.0, height_m=0.6)
    bodies = Bodies.from_specs([RobotSpec(f"r{i}", id=i + 1, com=0.7, **shape) for i in range(n)])  # type: ignore[arg-type]
    p_now = np.asarray(now, dtype=float)
    p_next = p_now + np.asarray(moves[:n], dtype=float)
    p_mid = interpolate_pose(p_now, p_next, 0.5)
    c_now, c_mid, c_next = (to_world(bodies.outline, p[:, 0], p[:, 1], p[:, 2]) for p in (p_now, p_mid, p_next))
    wall_free = np.asarray(free[:n], dtype=bool)
    want_walls, want_robots, gap = _reference(scene, c_now, c_mid, c_next, wall_free)
    assume(gap > 1000 * TOUCH_M)  # not within a rounding error of touching
    got_walls, got_robots = touching(scene, c_now, c_mid, c_next, wall_free)
    assert {(int(a), int(b)) for a, b in got_walls} == want_walls
    assert {(int(a), int(b)) for a, b in got_robots} == want_robots
    assert got_walls.tolist() == sorted(got_walls.tolist())
    assert got_robots.tolist() == sorted(got_robots.tolist())


def test_touching_outlines_count_as_contact() -> None:
    # two squares sharing an edge exactly, and a third a rounding error away
    sq = np.asarray([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    c = np.stack([sq + [2.0, 2.0], sq + [3.0, 2.0], sq + [4.0 + TOUCH_M / 2, 2.0]])
    _, robots = touching(Scene(Lab("t", W, H)), c, c, c, np.zeros(3, dtype=bool))
    assert robots.tolist() == [[0, 1], [1, 2]]


def test_a_body_wholly_inside_a_wall_and_a_wall_wholly_inside_a_body() -> None:
    big = Wall(((1.0, 1.0), (5.0, 1.0), (5.0, 5.0), (1.0, 5.0)), 1.0)
    small = Wall(((6.4, 2.4), (6.6, 2.4), (6.5, 2.6)), 1.0)
    scene = Scene(Lab("t", W, H, (big, small)))
    sq = np.asarray([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    c = np.stack([sq + [2.0, 2.0], sq + [6.0, 2.0]])
    walls_hit, _ = touching(scene, c, c, c, np.zeros(2, dtype=bool))
    assert walls_hit.tolist() == [[0, 0], [1, 1]]
