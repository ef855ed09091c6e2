"""The sensors node's logic without a bus: shards, noise streams and encoders across ticks."""

from __future__ import annotations

from iw_zenoh.core.lab import Lab, Scene
from iw_zenoh.core.spec import IrSensorSpec, RobotSpec
from iw_zenoh.messages import SensorReading, WorldInfo, WorldState, lab_to_msg, spec_to_msg
from iw_zenoh.nodes.info import WorldView
from iw_zenoh.nodes.sensors import SensorsNode
from tests.conftest import box_wall

LAB = Lab("t", 20.0, 10.0, (box_wall(9.0, 0.0, 10.0, 3.0),))
CONES = tuple(IrSensorSpec(k, 0.3, 0.0, 90.0 * k - 90.0, 60.0, 4.0) for k in range(4))


def _view(ids: list[int], revision: int) -> WorldView:
    specs = {i: RobotSpec(f"r{i}", id=i, ir_sensors=CONES) for i in ids}  # default noise: on
    info = WorldInfo(
        revision=revision, lab=lab_to_msg(LAB), period_ns=100_000_000, robots=[spec_to_msg(s) for s in specs.values()]
    )
    return WorldView(info, Scene(LAB), specs)


def _state(tick: int, ids: list[int], revision: int) -> WorldState:
    n = len(ids)
    return WorldState(
        tick=tick,
        sim_time_ns=tick * 100_000_000,
        revision=revision,
        ids=ids,
        x=[2.0 + 1.5 * i + 0.01 * tick for i in ids],
        y=[5.0 + 0.3 * (i % 2) for i in ids],
        heading=[0.1 * i for i in ids],
        collided=[False] * n,
        rolled_left=[0.01] * n,
        rolled_right=[0.012] * n,
        speed=[0.1] * n,
    )


def _run(shards: list[tuple[int, int]]) -> dict[tuple[int, int], SensorReading]:
    """Five ticks; robot 3 joins at tick 3 and robot 1 leaves at tick 4 (the roster changes)."""
    nodes = [SensorsNode("t", seed=5, shard=s) for s in shards]
    rosters = [([1, 2], 1), ([1, 2], 1), ([1, 2, 3], 2), ([2, 3], 3), ([2, 3], 3)]
    out: dict[tuple[int, int], SensorReading] = {}
    for tick, (ids, revision) in enumerate(rosters, start=1):
        view = _view(ids, revision)
        for node in nodes:
            for _, reading in node.on_state(_state(tick, ids, revision), view):
                assert isinstance(reading, SensorReading)
                assert (tick, reading.robot_id) not in out  # every robot in exactly one shard
                out[(tick, reading.robot_id)] = reading
    return out


def test_shards_read_what_one_node_reads_for_every_robot_through_roster_changes() -> None:
    whole = _run([(1, 1)])
    split = _run([(1, 2), (2, 2)])
    assert sorted(whole) == sorted(split)
    assert whole == split  # noise included: each robot's own stream, whichever shard
    assert len(whole) == 2 + 2 + 3 + 2 + 2


def test_encoders_accumulate_and_a_robot_keeps_its_count_when_others_come_and_go() -> None:
    r = _run([(1, 1)])
    left = [r[(t, 2)].encoders[0] for t in range(1, 6)]
    assert all(b > a for a, b in zip(left, left[1:], strict=False))  # robot 2 rolls forward every tick
    assert r[(3, 3)].encoders[0] < left[2] / 2  # robot 3 starts counting when it joins
    # the noise of robot 2's readings is its own stream's: the same whatever else is there
    alone = SensorsNode("t", seed=5)
    first = [alone.on_state(_state(t, [2], 1), _view([2], 1))[0][1] for t in (1, 2)]
    assert [m.compass_deg for m in first] == [r[(t, 2)].compass_deg for t in (1, 2)]  # type: ignore[attr-defined]
