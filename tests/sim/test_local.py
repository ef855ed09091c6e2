"""The tick in one process: a chair driven into a wall collides, readings answer each step, what
is said is heard with the next readings, and the same seed and commands give the same run."""

from __future__ import annotations

import pytest

from iw_zenoh.core.lab import Grid, GridPosition, Lab
from iw_zenoh.core.spec import prototype_chair
from iw_zenoh.errors import IwError
from iw_zenoh.sim.local import LocalWorld
from tests.support.builders import box_wall


def _world(seed: int = 3) -> LocalWorld:
    lab = Lab("t", 20.0, 10.0, (box_wall(9.0, 0.0, 10.0, 10.0),))
    return LocalWorld(lab, Grid((GridPosition(2, 5, 0), GridPosition(5, 5, 0))), seed=seed)


def _drive(seed: int) -> list[tuple[object, ...]]:
    w = _world(seed)
    a, b = w.add(prototype_chair("a")), w.add(prototype_chair("b"))
    out: list[tuple[object, ...]] = []
    s = w.step()
    for _ in range(60):
        s = w.step({b: (0.15, 0.15)}, say={a: "hello"})
        out.append((s.state.x, s.state.y, s.readings[a].proximity_m, s.readings[b].compass_deg))
    return out


def test_a_chair_driven_at_a_wall_collides_and_its_reading_says_so() -> None:
    w = _world()
    rid = w.add(prototype_chair("me", id=2))
    s = w.step()
    assert s.state.tick == 1
    assert rid in s.readings
    for _ in range(100):
        s = w.step({rid: (0.15, 0.15)})
        if s.readings[rid].collision:
            break
    assert s.readings[rid].collision
    assert any(e.kind == "collision" and e.robot_id == rid for e in s.events) or w.world.collisions == 1


def test_what_a_robot_says_with_its_commands_is_heard_with_that_steps_readings_within_range() -> None:
    w = _world()
    a, b = w.add(prototype_chair("a")), w.add(prototype_chair("b"))
    heard = w.step(say={a: "hi"}).heard
    assert [m.text for m in heard[b]] == ["hi"]
    assert [m.sender for m in heard[a]] == [a]
    assert w.step().heard == {}


def test_the_same_seed_and_commands_give_the_same_run_and_another_seed_another() -> None:
    assert _drive(4) == _drive(4)
    assert _drive(4) != _drive(5)


def test_a_robot_the_world_refuses_is_an_error_naming_it() -> None:
    w = _world()
    w.add(prototype_chair("a", id=1))
    with pytest.raises(IwError, match="'b' refused"):
        w.add(prototype_chair("b", id=1))
