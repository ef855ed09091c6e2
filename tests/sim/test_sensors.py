"""The sensors node's logic without a bus: shards, noise streams and encoders across ticks."""

from __future__ import annotations

import msgspec

from iw_zenoh.convert import lab_to_msg, spec_to_msg
from iw_zenoh.core.lab import Lab, Scene
from iw_zenoh.core.spec import IrSensorSpec, LaserSpec, RobotSpec
from iw_zenoh.messages import SensorReading, WorldInfo, WorldState, encode
from iw_zenoh.sim.sensors import SensorsNode
from iw_zenoh.sim.view import WorldView
from tests.support.builders import box_wall, proposal_of

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


def test_readings_computed_ahead_from_the_proposal_equal_those_of_the_state_bit_for_bit() -> None:
    # robots 1-3 about 1.5 m apart, 4 and 5 far from them and from each other
    ids = [1, 2, 3, 4, 5]
    view = _view(ids, 1)
    far = {4: 12.0, 5: 17.0}

    def state(tick: int) -> WorldState:
        st = _state(tick, ids, 1)
        return msgspec.structs.replace(
            st, x=[far.get(i, x) for i, x in zip(ids, st.x, strict=True)], tick_wall_ns=1000 + tick
        )

    reference = SensorsNode("t", seed=5)
    ahead_node = SensorsNode("t", seed=5)
    again_counts = []
    for tick in range(1, 7):
        proposed = state(tick)
        committed = proposed
        if tick == 2:  # robot 1 collided: it stays where it was, its flag set
            prev = state(tick - 1)
            committed = msgspec.structs.replace(
                proposed,
                x=[prev.x[0], *proposed.x[1:]],
                collided=[True, False, False, False, False],
            )
        if tick == 4:  # everybody held: nobody moves
            committed = msgspec.structs.replace(proposed, x=state(tick - 1).x, rolled_left=[0.0] * 5)
        want = [encode(m) for _, m in reference.on_state(committed, view)]
        ahead = ahead_node.ahead(proposal_of(proposed), view)
        assert ahead is not None
        got, again = ahead_node.settle(ahead, committed, view)
        assert got.encoded == want, f"tick {tick}"
        again_counts.append(again)
    # tick 2: only robot 1 and the robots its body or cones reach were computed again
    assert again_counts == [0, 3, 0, 5, 0, 0]


def test_computing_ahead_needs_the_previous_ticks_readings_out() -> None:
    node = SensorsNode("t", seed=5)
    view = _view([1, 2], 1)
    node.on_state(_state(1, [1, 2], 1), view)
    assert node.ahead(proposal_of(_state(3, [1, 2], 1)), view) is None  # tick 2 not out yet
    assert node.ahead(proposal_of(_state(2, [1, 2], 1)), view) is not None


def test_a_proposal_of_an_older_world_that_does_not_say_how_far_the_wheels_rolled_is_not_computed_ahead() -> None:
    node = SensorsNode("t", seed=5)
    st = _state(1, [1, 2], 1)
    old = msgspec.structs.replace(proposal_of(st), rolled_left=[], rolled_right=[])
    assert node.ahead(old, _view([1, 2], 1)) is None
    assert node.ahead(proposal_of(st), _view([1, 2], 1)) is not None


def test_a_robot_with_a_laser_scanner_gets_its_scan_and_one_without_reads_as_before() -> None:
    specs = {
        1: RobotSpec("r1", id=1, ir_sensors=CONES, lasers=(LaserSpec(0, 0.3, 0.0, 0.0, 90.0, 5, 12.0),)),
        2: RobotSpec("r2", id=2, ir_sensors=CONES),
    }
    info = WorldInfo(
        revision=1, lab=lab_to_msg(LAB), period_ns=100_000_000, robots=[spec_to_msg(s) for s in specs.values()]
    )
    out = dict(SensorsNode("t", seed=5).on_state(_state(1, [1, 2], 1), WorldView(info, Scene(LAB), specs)))
    with_laser, without = out["iw/t/robot/1/sensors"], out["iw/t/robot/2/sensors"]
    assert isinstance(with_laser, SensorReading)
    assert isinstance(without, SensorReading)
    assert isinstance(with_laser.lasers, list)
    [scan] = with_laser.lasers
    assert scan.id == 0
    assert len(scan.ranges) == 5
    assert scan.ranges[2] is not None
    assert 0.4 < scan.ranges[2] < 1.0
    assert without.lasers is msgspec.UNSET
    assert b"lasers" not in encode(without)


def test_warming_a_roster_builds_its_bodies_and_changes_no_reading() -> None:
    cold, warm = SensorsNode("t", seed=5), SensorsNode("t", seed=5)
    view = _view([1, 2], 1)
    warm.warm(view)
    assert (1, 2) in view._bodies  # built before the first state waits on it
    assert warm.last_tick == -1  # nothing committed
    for tick in (1, 2):
        st = _state(tick, [1, 2], 1)
        assert warm.on_state(st, view) == cold.on_state(st, _view([1, 2], 1))  # noise and encoders too


def test_readings_sent_early_then_checked_by_their_state_match_a_node_that_waited_every_tick() -> None:
    # tick 3 is held after the verdict confirmed it (the world took it too late): the state
    # corrects it, and every later tick reads as if nothing had gone out early (encoders, noise)
    ids = [1, 2, 3]
    view = _view(ids, 1)
    reference, early = SensorsNode("t", seed=5), SensorsNode("t", seed=5)
    for tick in range(1, 7):
        proposed = _state(tick, ids, 1)
        committed = proposed
        if tick == 3:
            committed = msgspec.structs.replace(
                proposed, x=_state(2, ids, 1).x, rolled_left=[0.0] * 3, rolled_right=[0.0] * 3, held=True
            )
        want = {m.robot_id: encode(m) for _, m in reference.on_state(committed, view)}  # type: ignore[attr-defined]
        ahead = early.ahead(proposal_of(proposed), view)
        assert ahead is not None
        early.send_early(ahead)
        assert early.ahead(proposal_of(_state(tick + 1, ids, 1)), view) is None  # not before the state checked it
        sent = {m.robot_id: e for (_, m), e in zip(ahead.out, ahead.encoded, strict=True)}
        fixed = early.check_early(committed, view)
        if tick != 3:
            assert fixed is None, f"tick {tick}"  # the state is what went out: nothing more
            assert sent == want, f"tick {tick}"
            continue
        assert fixed is not None
        assert fixed.msg.tick == 3
        assert sent != want
        # only the readings that differ go out again, and they are the state's
        again = {m.robot_id: e for (_, m), e in zip(fixed.out, fixed.encoded, strict=True)}
        assert again
        assert {**sent, **again} == want
        assert all(sent[r] != e for r, e in again.items())
    assert early.corrections == 1
