from __future__ import annotations

import io

from iw_zenoh import keys
from iw_zenoh.convert import lab_to_msg, spec_to_msg
from iw_zenoh.core.lab import Lab
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import Event, WorldInfo, WorldState, encode
from iw_zenoh.record.incidents import find_incidents
from iw_zenoh.record.recording import Recorder

TICK = 100_000_000


def _recording() -> io.BytesIO:
    """Two 1 x 1 chairs closing on each other at 0.1 m a tick, touching at tick 10."""
    buf = io.BytesIO()
    rec = Recorder(buf)
    specs = [
        spec_to_msg(RobotSpec("a", id=1, x_m=5.0, y_m=5.0, dir_deg=0.0)),
        spec_to_msg(RobotSpec("b", id=2, x_m=8.0, y_m=5.0, dir_deg=180.0)),
    ]
    info = WorldInfo(revision=1, lab=lab_to_msg(Lab("open", 20.0, 10.0)), period_ns=TICK, robots=specs)
    rec.add(keys.info("s"), encode(info), 1)
    for t in range(1, 13):
        gap = max(0.0, 2.0 - 0.2 * t)  # between the bodies
        xa = 5.0 + (2.0 - gap) / 2
        xb = 8.0 - (2.0 - gap) / 2
        touching = gap <= 0.0
        st = WorldState(
            tick=t,
            sim_time_ns=t * TICK,
            revision=1,
            ids=[1, 2],
            x=[xa, xb],
            y=[5.0, 5.0],
            heading=[0.0, 3.14159],
            collided=[touching, touching],
            rolled_left=[0.0, 0.0],
            rolled_right=[0.0, 0.0],
            speed=[0.1, 0.1],
        )
        rec.add(keys.state("s"), encode(st), t * TICK)
        if t == 10:
            ev = Event(
                tick=t,
                sim_time_ns=t * TICK,
                kind="collision",
                reason="robot 1 hit robot 2",
                robot_id=1,
                data={"x": xa, "y": 5.0},
            )
            rec.add(keys.event("s", "collision"), encode(ev), t * TICK + 1)
    rec.finish()
    buf.seek(0)
    return buf


def test_a_scripted_collision_and_the_near_miss_before_it_are_found_at_their_times() -> None:
    found = find_incidents(_recording(), near_m=0.2)
    kinds = [(i.kind, round(i.t, 1)) for i in found]
    assert ("near-miss", 0.9) in kinds  # 0.2 m apart at tick 9
    assert ("collision", 1.0) in kinds
    col = next(i for i in found if i.kind == "collision")
    assert col.robots == [1]
    assert col.where[0][0] > 5.9
    near = next(i for i in found if i.kind == "near-miss")
    assert near.robots == [1, 2]


def test_door_leaves_on_one_hub_and_in_their_wall_are_no_near_miss_but_a_chair_by_a_leaf_is() -> None:
    from iw_zenoh.core.lab import Wall
    from iw_zenoh.core.spec import RobotType

    buf = io.BytesIO()
    rec = Recorder(buf)
    leaf = {"type": RobotType.DOOR, "width_m": 1.6, "height_m": 0.1, "com": 0.98, "x_m": 10.0, "y_m": 5.0}
    specs = [
        spec_to_msg(RobotSpec("leaf-0", id=1, dir_deg=90.0, **leaf)),  # type: ignore[arg-type]
        spec_to_msg(RobotSpec("leaf-1", id=2, dir_deg=-30.0, **leaf)),  # type: ignore[arg-type]
        spec_to_msg(RobotSpec("chair", id=3, width_m=1.0, height_m=0.6, x_m=8.0, y_m=5.0)),
    ]
    wall = Wall(((9.95, 6.7), (10.05, 6.7), (10.05, 10.0), (9.95, 10.0)))  # leaf 0 reaches into it
    info = WorldInfo(revision=1, lab=lab_to_msg(Lab("door", 20.0, 10.0, (wall,))), period_ns=TICK, robots=specs)
    rec.add(keys.info("s"), encode(info), 1)
    st = WorldState(
        tick=1,
        sim_time_ns=TICK,
        revision=1,
        ids=[1, 2, 3],
        x=[10.0, 10.0, 9.3],  # the chair's front 0.15 m from leaf 0
        y=[5.0, 5.0, 6.0],
        heading=[1.5708, -0.5236, 0.0],
        collided=[False, False, False],
        rolled_left=[0.0] * 3,
        rolled_right=[0.0] * 3,
        speed=[0.0] * 3,
    )
    rec.add(keys.state("s"), encode(st), TICK)
    rec.finish()
    buf.seek(0)
    found = find_incidents(buf, near_m=0.2)
    assert [i.robots for i in found] == [[1, 3]]  # the chair by leaf 0; not the leaves, nor leaf 0 in its wall
