"""The rule that lets the sensors and the radio publish tick n before the world commits it: a
verdict confirms a proposal exactly when the world, taking it, commits the proposal's next poses.
Each case is checked against the world's own logic (WorldCore), not against a copy of the rule."""

from __future__ import annotations

import msgspec

from iw_zenoh.core.lab import Grid, GridPosition, Lab
from iw_zenoh.messages import Actions, PoseReport, Proposed, RegisterRequest, RobotSpecMsg, Verdict, WorldState, encode
from iw_zenoh.sim.config import MS, WorldConfig
from iw_zenoh.sim.early import VERDICTS_A_TICK, Verdicts, confirms, state_from_proposal
from iw_zenoh.sim.world import WorldCore
from tests.support.builders import box_wall, world_state


def _core(*robots: RobotSpecMsg, **kw: object) -> WorldCore:
    lab = Lab("t", 20.0, 10.0, (box_wall(9.0, 0.0, 10.0, 3.0),))
    grid = Grid((GridPosition(2, 5, 0), GridPosition(5, 5, 0), GridPosition(8.4, 5, 0)))
    core = WorldCore(WorldConfig(sim="t", **kw), lab, grid)  # type: ignore[arg-type]
    core.collision_alive.add("c")
    for spec in robots or (RobotSpecMsg(name="a"), RobotSpecMsg(name="b")):
        assert core.register(RegisterRequest(spec=spec), 0)[0].ok
    return core


def _propose(core: WorldCore, k: int) -> Proposed:
    for rid in core.registry.arrayed:
        core.on_actions(Actions(tick=core.tick, robot_id=rid, left=0.15, right=0.12), k * 100 * MS)
    return next(m for _, m in core.begin_tick(k * 100 * MS, wall_ns=1000 + k) if isinstance(m, Proposed))


def _verdict(p: Proposed, collided: list[bool] | None = None) -> Verdict:
    return Verdict(tick=p.tick, revision=p.revision, ids=p.ids, collided=collided or [False] * len(p.ids))


def _commit(core: WorldCore, v: Verdict | None) -> WorldState:
    return next(m for _, m in core.finish_tick(v) if isinstance(m, WorldState))


def _read(s: WorldState) -> tuple[object, ...]:
    """All of a state the sensors and the radio read."""
    return (s.tick, s.sim_time_ns, s.revision, s.ids, s.x, s.y, s.heading, s.collided, s.rolled_left, s.rolled_right)


def _confirmed_and_committed(core: WorldCore, p: Proposed, v: Verdict) -> bool:
    assert core.verdict_ok(v)
    committed = _commit(core, v)
    return confirms(p, v) and _read(committed) == _read(state_from_proposal(p))


def test_a_clean_verdict_confirms_and_the_world_commits_the_proposal() -> None:
    core = _core()
    for k in range(1, 4):
        p = _propose(core, k)
        v = _verdict(p)
        assert _confirmed_and_committed(core, p, v)
        assert confirms(state_from_proposal(p), v)  # the state made from it is judged the same


def test_a_flag_set_in_the_tick_before_does_not_stay_set() -> None:
    # robot 3 starts 0.1 m from a wall and drives into it: its verdict flags it at tick 1
    core = _core(RobotSpecMsg(name="a"), RobotSpecMsg(name="b"), RobotSpecMsg(name="c"))
    p = _propose(core, 1)
    hit = _verdict(p, [False, False, True])
    assert not confirms(p, hit)
    assert _commit(core, hit).collided == [False, False, True]
    p = _propose(core, 2)  # the next verdict flags nobody (the collision process let it go)
    assert _confirmed_and_committed(core, p, _verdict(p))


def test_a_real_robot_s_reported_pose_is_already_the_proposal_s() -> None:
    core = _core(RobotSpecMsg(name="a"), RobotSpecMsg(name="real", type="Real"))
    core.on_pose_report(PoseReport(tick=0, robot_id=2, x=6.0, y=4.0, dir_deg=30.0), 0)
    p = _propose(core, 1)
    assert (p.next_x[1], p.next_y[1]) == (6.0, 4.0)
    assert _confirmed_and_committed(core, p, _verdict(p))
    p = _propose(core, 2)  # no report this tick: held where it was, in the proposal as well
    assert _confirmed_and_committed(core, p, _verdict(p))


def test_a_verdict_that_flags_a_robot_does_not_confirm() -> None:
    core = _core()
    p = _propose(core, 1)
    v = _verdict(p, [True, False])
    assert not confirms(p, v)
    assert _read(_commit(core, v)) != _read(state_from_proposal(p))  # robot 1 kept its pose


def test_a_verdict_on_another_tick_revision_or_roster_does_not_confirm() -> None:
    core = _core()
    p = _propose(core, 1)
    v = _verdict(p)
    for other in (
        msgspec.structs.replace(v, tick=p.tick + 1),
        msgspec.structs.replace(v, tick=p.tick - 1),
        msgspec.structs.replace(v, revision=p.revision + 1),
        msgspec.structs.replace(v, ids=[p.ids[1], p.ids[0]]),
        Verdict(tick=p.tick, revision=p.revision, ids=p.ids[:1], collided=[False]),
    ):
        assert not confirms(p, other)
        assert not core.verdict_ok(other)  # nor does the world take it


def test_a_robot_removed_after_the_proposal_makes_the_world_refuse_the_verdict_it_confirmed() -> None:
    # the world takes no input between proposing and committing, but if it did, the roster would
    # not be the proposal's and the world would not take the verdict: it holds the tick, which the
    # early receivers learn from the state and correct
    core = _core()
    p = _propose(core, 1)
    v = _verdict(p)
    core.remove(2, "gone")
    assert confirms(p, v)
    assert not core.verdict_ok(v)


def test_a_verdict_the_world_did_not_take_in_time_confirms_but_the_tick_is_held() -> None:
    # the one case the rule cannot see: the world held the tick (the verdict came after its
    # deadline); the state then differs and the early receivers send the correction
    core = _core()
    _commit(core, _verdict(_propose(core, 1)))
    p = _propose(core, 2)  # moving now (the motors ramp up from rest in tick 1)
    assert confirms(p, _verdict(p))
    held = _commit(core, None)
    assert held.held
    assert _read(held) != _read(state_from_proposal(p))


def test_the_verdict_store_keeps_the_newest_and_confirms_only_its_own_tick() -> None:
    from iw_zenoh.messages import encode
    from iw_zenoh.sim.early import Verdicts

    store = Verdicts(kept=2)
    ok = [Verdict(tick=t, revision=1, ids=[1], collided=[False]) for t in (1, 2, 3)]
    store.take([encode(ok[0]), b"not a verdict", b'{"tick": -1}', encode(ok[1]), encode(ok[2])])

    def asked(tick: int) -> WorldState:
        return WorldState(
            tick=tick, sim_time_ns=0, revision=1, ids=[1], x=[1.0], y=[1.0], heading=[0.0],
            collided=[False], rolled_left=[0.0], rolled_right=[0.0], speed=[0.0],
        )  # fmt: skip

    assert not store.confirm(asked(1))  # the oldest went: two kept
    assert store.confirm(asked(2))
    assert store.confirm(asked(3))
    assert not store.confirm(asked(4))  # no verdict for it yet
    store.take([encode(Verdict(tick=4, revision=1, ids=[1], collided=[True]))])
    assert not store.confirm(asked(4))  # a verdict that flags the robot confirms nothing


def _v(tick: int, ids: list[int] | None = None, *, revision: int = 1, collided: bool = False) -> bytes:
    ids = [1] if ids is None else ids
    return encode(Verdict(tick=tick, revision=revision, ids=ids, collided=[collided] * len(ids)))


def test_the_verdict_store_refuses_garbage_a_tick_too_far_ahead_and_too_many_for_a_tick_saying_why() -> None:
    store = Verdicts()
    store.settle(world_state(10))
    far = "tick 1000000000000000 is too far"
    store.take([b"\xff garbage", _v(10**15)], ahead=lambda t: far if t > 1000 else "")
    store.take([_v(11, collided=True) for _ in range(VERDICTS_A_TICK + 2)])
    why = store.refusals()
    assert len(why) == 4
    assert "JSON" in why[0] or "decode" in why[0].lower(), why[0]
    assert why[1] == f"verdict: {far}"
    assert why[2] == f"a verdict of tick 11 past the {VERDICTS_A_TICK} kept for a tick"
    assert why[3] == why[2]
    assert store.refusals() == []  # told once


def test_the_first_verdict_that_answers_the_proposal_counts_and_the_others_are_refused_with_its_state() -> None:
    store = Verdicts(per_tick=5)
    store.settle(world_state(10))
    store.take([_v(11, revision=7), _v(11, [1, 999]), _v(11, list(range(1, 100_001))), _v(11), _v(11, collided=True)])
    assert store.confirm(world_state(11))  # the other revision and robots do not answer it; then the first that does
    assert store.refusals() == []  # nothing is refused before the state of its tick says what the world had
    store.settle(world_state(11))
    why = store.refusals()
    assert len(why) == 3
    assert "answers revision 7 and robots [1]" in why[0]
    assert "robots [1, 999] (2)" in why[1]
    assert "(100000), not the world's: revision 1, robots [1] (1)" in why[2]
    assert not store.confirm(world_state(11))  # forgotten once its state came


def test_verdicts_of_ticks_settled_or_beyond_the_kept_ones_are_dropped_unrefused() -> None:
    store = Verdicts(kept=4)
    store.settle(world_state(10))
    store.take([_v(9), _v(10), _v(15), _v(14)])  # late ones; one further ahead than the four kept
    assert store.refusals() == []
    assert [store.confirm(world_state(t)) for t in (9, 10, 14, 15)] == [False, False, True, False]
