"""A world description (period 50 ms) on a small lab, as the world publishes it."""

from __future__ import annotations

from iw_zenoh.convert import lab_to_msg
from iw_zenoh.core.lab import Lab
from iw_zenoh.messages import RobotSpecMsg, WorldInfo
from tests.support.builders import box_wall

INFO_LAB = Lab("t", 10.0, 6.0, (box_wall(4.0, 0.0, 4.2, 3.0),))


def world_info(revision: int, robots: int = 0) -> WorldInfo:
    specs = [RobotSpecMsg(name=f"r{i}", id=i, x_m=1.0 + i, y_m=4.0, legacy=True) for i in range(1, robots + 1)]
    return WorldInfo(revision=revision, lab=lab_to_msg(INFO_LAB), period_ns=50_000_000, robots=specs)
