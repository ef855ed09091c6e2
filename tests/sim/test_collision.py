"""The collision node's logic without a bus: which contacts make a verdict."""

from __future__ import annotations

import math

from iw_zenoh.convert import lab_to_msg, spec_to_msg
from iw_zenoh.core.lab import Lab, Scene
from iw_zenoh.core.spec import RobotSpec, RobotType
from iw_zenoh.messages import Proposed, WorldInfo
from iw_zenoh.sim.collision import CollisionNode
from iw_zenoh.sim.view import WorldView

LAB = Lab("t", 20.0, 10.0, ())


def _leaf(i: int, deg: float) -> RobotSpec:
    return RobotSpec(
        f"leaf{i}", id=i, type=RobotType.DOOR, width_m=1.6, height_m=0.1, com=0.98, x_m=10.0, y_m=5.0, dir_deg=deg
    )


def _verdict(specs: list[RobotSpec], poses: list[tuple[float, float, float]]) -> list[bool]:
    info = WorldInfo(revision=1, lab=lab_to_msg(LAB), period_ns=100_000_000, robots=[spec_to_msg(s) for s in specs])
    view = WorldView(info, Scene(LAB), {s.id: s for s in specs})
    ids = [s.id for s in specs]
    n = len(ids)
    xs, ys, hs = (list(v) for v in zip(*poses, strict=True))
    prop = Proposed(
        tick=1,
        sim_time_ns=100_000_000,
        revision=1,
        ids=ids,
        x=xs,
        y=ys,
        heading=hs,
        next_x=xs,
        next_y=ys,
        next_heading=hs,
        linear=[0.0] * n,
        active=[True] * n,
    )
    return CollisionNode().on_proposed(prop, view).collided


def test_the_leaves_of_a_revolving_door_cross_at_its_hub_without_colliding() -> None:
    leaves = [_leaf(i + 1, math.remainder(120.0 * i, 360.0)) for i in range(3)]
    poses = [(10.0, 5.0, math.radians(120.0 * i)) for i in range(3)]
    assert _verdict(leaves, poses) == [False, False, False]


def test_a_leaf_still_collides_with_a_chair() -> None:
    chair = RobotSpec("chair", id=4, width_m=1.0, height_m=0.6, x_m=11.0, y_m=5.0)
    assert _verdict([_leaf(1, 0.0), chair], [(10.0, 5.0, 0.0), (11.0, 5.0, 0.0)]) == [True, True]
