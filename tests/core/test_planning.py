from __future__ import annotations

import math

from iw_zenoh.core.lab import Lab
from iw_zenoh.core.planning import astar, configuration_space, mark_obstacles, plan
from iw_zenoh.maps import load_lab
from tests.support.builders import box_wall


def test_walls_grow_by_the_radius() -> None:
    grid = configuration_space(Lab("l", 10.0, 10.0, (box_wall(4, 0, 5, 6),)), 0.5)
    assert grid.blocked[grid.cell((3.6, 3.0))]  # 0.4 m from the wall
    assert not grid.blocked[grid.cell((3.3, 3.0))]
    assert grid.blocked[grid.cell((0.2, 5.0))]  # the border grows too


def test_a_path_goes_round_a_wall_and_every_step_is_free() -> None:
    grid = configuration_space(Lab("l", 10.0, 10.0, (box_wall(4, 0, 5, 7),)), 0.4)
    path = astar(grid, (2.0, 2.0), (8.0, 2.0))
    assert path is not None
    assert max(y for _, y in path) > 7.3  # over the top of the wall
    assert not any(grid.blocked[grid.cell(p)] for p in path)
    wps = plan(grid, (2.0, 2.0), (8.0, 2.0))
    assert wps is not None
    assert math.dist(wps[-1], (8.0, 2.0)) < 0.1
    assert len(wps) < len(path) / 5  # pruned to the corners that matter


def test_no_path_through_a_closed_door_and_a_path_once_open() -> None:
    closed = Lab("l", 10.0, 10.0, (box_wall(4.9, 0, 5.1, 10),))
    assert plan(configuration_space(closed, 0.3), (2.0, 5.0), (8.0, 5.0)) is None
    open_door = Lab("l", 10.0, 10.0, (box_wall(4.9, 0, 5.1, 4.4), box_wall(4.9, 5.6, 5.1, 10)))
    assert plan(configuration_space(open_door, 0.3), (2.0, 5.0), (8.0, 5.0)) is not None


def test_obstacles_seen_later_make_the_path_go_round() -> None:
    grid = configuration_space(Lab("l", 10.0, 4.0), 0.3)
    straight = plan(grid, (1.0, 2.0), (9.0, 2.0))
    assert straight == [grid.centre(grid.cell((9.0, 2.0)))]
    seen = mark_obstacles(grid, [(5.0, y / 10) for y in range(5, 25)], 0.3)
    around = plan(seen, (1.0, 2.0), (9.0, 2.0))
    assert around is not None
    assert len(around) > 1


def test_the_liacc_slalom_corridor_is_passable_for_the_prototype_chair() -> None:
    grid = configuration_space(load_lab("maps/liacc.xml"), 0.35)
    assert plan(grid, (10.0, 6.1), (20.0, 6.1)) is not None
