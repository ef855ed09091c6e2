from __future__ import annotations

import math

import numpy as np
import shapely
from hypothesis import given
from hypothesis import strategies as st

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.collision import check_collisions, check_collisions_ciberrato
from iw_zenoh.core.lab import Lab, Scene
from iw_zenoh.core.spec import RobotSpec
from tests.support.builders import box_wall


def _bodies(n: int, **kw: float) -> Bodies:
    return Bodies.from_specs([RobotSpec(f"r{i}", id=i + 1, **kw) for i in range(n)])  # type: ignore[arg-type]


def _check(scene: Scene, bodies: Bodies, now: list[list[float]], nxt: list[list[float]]):  # type: ignore[no-untyped-def]
    return check_collisions(scene, bodies.outline, np.asarray(now, float), np.asarray(nxt, float))


def test_free_move_collides_with_nothing(small_scene: Scene) -> None:
    c = _check(small_scene, _bodies(1), [[2.0, 2.0, 0.0]], [[2.1, 2.0, 0.0]])
    assert not c.collided.any()
    assert len(c.wall_pairs) == 0


def test_touching_a_wall_next_tick_collides_and_names_the_wall(small_scene: Scene) -> None:
    # 1 x 1 body centred at 4.45 reaches x = 4.95; at 4.55 it reaches 5.05 into the pillar
    c = _check(small_scene, _bodies(1), [[4.45, 2.5, 0.0]], [[4.55, 2.5, 0.0]])
    assert c.collided.tolist() == [True]
    assert c.hit_wall.tolist() == [True]
    assert c.wall_pairs.tolist() == [[0, 0]]


def test_leaving_the_lab_hits_the_border(small_scene: Scene) -> None:
    c = _check(small_scene, _bodies(1), [[0.6, 3.0, 0.0]], [[0.4, 3.0, 0.0]])
    assert c.wall_pairs.tolist() == [[0, 1]]  # index len(walls) is the border


def test_a_body_wholly_inside_a_wall_collides() -> None:
    scene = Scene(Lab("big wall", 20.0, 20.0, (box_wall(5.0, 5.0, 15.0, 15.0),)))
    c = _check(scene, _bodies(1), [[10.0, 10.0, 0.0]], [[10.0, 10.0, 0.1]])
    assert c.collided.tolist() == [True]


def test_a_small_obstacle_wholly_inside_the_body_collides() -> None:
    scene = Scene(Lab("post", 20.0, 20.0, (box_wall(10.0, 10.0, 10.05, 10.05),)))
    c = _check(scene, _bodies(1, width_m=2.0, height_m=2.0), [[7.0, 10.0, 0.0]], [[10.0, 10.0, 0.0]])
    assert c.collided.tolist() == [True]


def test_a_fast_body_cannot_tunnel_through_a_thin_wall() -> None:
    scene = Scene(Lab("thin", 20.0, 10.0, (box_wall(10.0, 0.0, 10.02, 10.0),)))
    # both poses are clear of the wall; the sweep between them is not
    c = _check(scene, _bodies(1, width_m=0.5, height_m=0.5), [[9.0, 5.0, 0.0]], [[11.0, 5.0, 0.0]])
    assert c.collided.tolist() == [True]
    assert c.wall_pairs.tolist() == [[0, 0]]


def test_a_body_in_contact_can_back_away_and_turn(small_scene: Scene) -> None:
    touching = [[4.5, 2.5, 0.0]]  # front edge on x = 5.0, the pillar's face
    back = _check(small_scene, _bodies(1), touching, [[4.4, 2.5, 0.0]])
    assert not back.collided.any()
    deeper = _check(small_scene, _bodies(1), touching, [[4.6, 2.5, 0.0]])
    assert deeper.collided.all()


def test_two_bodies_meeting_head_on_both_collide(small_scene: Scene) -> None:
    c = _check(small_scene, _bodies(2), [[1.0, 5.0, 0.0], [2.3, 5.0, math.pi]], [[1.2, 5.0, 0.0], [2.1, 5.0, math.pi]])
    assert c.collided.tolist() == [True, True]
    assert c.robot_pairs.tolist() == [[0, 1]]


def test_a_robot_wholly_inside_another_collides() -> None:
    scene = Scene(Lab("open", 20.0, 20.0))
    b = Bodies.from_specs(
        [RobotSpec("big", id=1, width_m=3.0, height_m=3.0), RobotSpec("small", id=2, width_m=0.2, height_m=0.2)]
    )
    c = _check(scene, b, [[10.0, 10.0, 0.0], [15.0, 15.0, 0.0]], [[10.0, 10.0, 0.0], [10.0, 10.0, 0.0]])
    assert c.collided.tolist() == [True, True]


def test_inactive_robots_take_no_part(small_scene: Scene) -> None:
    b = _bodies(2)
    now = np.array([[1.0, 5.0, 0.0], [2.3, 5.0, math.pi]])
    nxt = np.array([[1.2, 5.0, 0.0], [2.1, 5.0, math.pi]])
    c = check_collisions(small_scene, b.outline, now, nxt, active=np.array([True, False]))
    assert not c.collided.any()


poses = st.tuples(st.floats(1.0, 9.0), st.floats(1.0, 5.0), st.floats(-math.pi, math.pi))


@given(a=poses, b=poses, da=poses, db=poses)
def test_robot_collision_is_symmetric_and_exact(a, b, da, db) -> None:  # type: ignore[no-untyped-def]
    scene = Scene(Lab("open", 10.0, 6.0))
    bodies = _bodies(2, width_m=1.2, height_m=0.7, com=0.8)
    now = np.array([a, b])
    nxt = np.array([da, db])
    c = check_collisions(scene, bodies.outline, now, nxt)
    assert c.hit_robot[0] == c.hit_robot[1]
    pa, pb = (shapely.Polygon(p) for p in bodies.world_outline(nxt))
    if pa.intersects(pb):  # the next outlines overlapping always counts
        assert c.hit_robot.all()


def test_ciberrato_wall_rule_is_centre_distance_under_half(small_scene: Scene) -> None:
    now = np.array([[4.4, 2.5, 0.0]])
    near = check_collisions_ciberrato(small_scene, now, np.array([[4.51, 2.5, 0.0]]), np.array([0.11]))
    far = check_collisions_ciberrato(small_scene, now, np.array([[4.49, 2.5, 0.0]]), np.array([0.09]))
    assert near.collided.tolist() == [True]
    assert far.collided.tolist() == [False]


def test_ciberrato_flags_only_the_robot_moving_towards_the_other() -> None:
    scene = Scene(Lab("open", 28.0, 14.0))
    now = np.array([[5.0, 7.0, 0.0], [6.0, 7.0, 0.0]])  # robot 0 behind robot 1, both facing +x
    nxt = np.array([[5.1, 7.0, 0.0], [6.0, 7.0, 0.0]])
    c = check_collisions_ciberrato(scene, now, nxt, np.array([0.1, 0.0]))
    assert c.collided.tolist() == [True, False]
    backing = check_collisions_ciberrato(scene, now, nxt, np.array([-0.1, 0.0]))
    assert backing.collided.tolist() == [False, False]


def test_doors_pass_walls_but_still_hit_robots(small_scene: Scene) -> None:
    b = _bodies(2)
    now = np.array([[4.45, 2.5, 0.0], [2.0, 5.0, 0.0]])
    nxt = np.array([[4.55, 2.5, 0.0], [2.0, 5.0, 0.0]])
    free = check_collisions(small_scene, b.outline, now, nxt, ignore_walls=np.array([True, False]))
    assert not free.collided.any()
    on_robot = np.array([[2.9, 5.0, 0.0], [2.0, 5.0, 0.0]])
    hit = check_collisions(
        small_scene,
        b.outline,
        np.array([[2.5, 5.0, 0.0], [1.0, 5.0, 0.0]]),
        on_robot,
        ignore_walls=np.array([True, False]),
    )
    assert hit.hit_robot.tolist() == [True, True]
