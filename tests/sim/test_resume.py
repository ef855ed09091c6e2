"""A world restarted from its last committed state goes on as the first would have."""

from __future__ import annotations

import msgspec
import pytest

from iw_zenoh.messages import Actions, Control, Event, Obstacle, RegisterRequest, RobotSpecMsg, WorldState
from iw_zenoh.sim.config import MS
from iw_zenoh.sim.resume import WorldSnapshot, resume, snapshot
from iw_zenoh.sim.world import WorldCore
from tests.support.sim_core import event_kinds as _kinds
from tests.support.sim_core import step as _tick
from tests.support.sim_core import world_core as _core


def _driven() -> tuple[WorldCore, WorldState]:
    """A world of two robots of two agents, one driven forward and turning, after 20 ticks."""
    core = _core()
    for agent in ("ag-a", "ag-b"):  # their tokens (a robot whose agent never appears is removed)
        core.on_alive("agent", agent, True, 0)
    assert core.register(RegisterRequest(spec=RobotSpecMsg(name="a"), agent="ag-a", request_id="11-1"), 0)[0].ok
    assert core.register(RegisterRequest(spec=RobotSpecMsg(name="b"), agent="ag-b", request_id="12-1"), 0)[0].ok
    ob = Obstacle(name="X", x0=15.0, y0=1.0, x1=16.0, y1=2.0)
    core.on_control(Control(command="add_obstacle", obstacle=ob))
    st = None
    for n in range(1, 21):
        core.on_actions(Actions(tick=n - 1, robot_id=1, left=0.1, right=0.12), n * 100 * MS)
        st = _tick(core, n * 100 * MS)
    assert st is not None
    return core, st


def _resumed(core: WorldCore, st: WorldState, now_ns: int) -> WorldCore:
    snap = snapshot(st, core.info(), {1: "ag-a", 2: "ag-b"}, running=True)
    snap = msgspec.json.decode(msgspec.json.encode(snap), type=WorldSnapshot)  # as iwz run hands it over
    again = _core()
    for o in snap.obstacles:
        again.on_control(Control(command="add_obstacle", obstacle=o))
    resume(again, snap, now_ns)
    return again


def test_a_resumed_world_goes_on_from_the_same_tick_poses_robots_and_obstacles() -> None:
    core, st = _driven()
    again = _resumed(core, st, 10**12)
    assert again.tick == st.tick == 20
    assert again.registry.ids == [1, 2]
    assert [e.agent for e in again.registry.entries.values()] == ["ag-a", "ag-b"]
    assert list(again.obstacles.by_name) == ["X"]
    assert again.revision > core.revision  # every node asks for the description again
    # both go on: the same next pose from the same motors (no noise in this world)
    for w in (core, again):
        w.on_alive("agent", "ag-a", True, 10**12)
        w.on_actions(Actions(tick=20, robot_id=1, left=0.1, right=0.12), 10**12)
    a = _tick(core, 10**12 + 100 * MS)
    b = _tick(again, 10**12 + 100 * MS)
    assert b.tick == 21
    assert b.x == pytest.approx(a.x, abs=1e-9)
    assert b.y == pytest.approx(a.y, abs=1e-9)
    assert b.heading == pytest.approx(a.heading, abs=1e-9)
    assert b.speed == pytest.approx(a.speed, abs=1e-9)


def test_the_time_a_world_was_down_trips_no_watchdog_and_a_dead_agent_is_removed_after_grace() -> None:
    core, st = _driven()
    down = 30 * 10**9  # the new world starts long after the last action
    again = _resumed(core, st, down)
    again.on_alive("agent", "ag-a", True, down)  # ag-b never comes back
    again.on_actions(Actions(tick=20, robot_id=1, left=0.1, right=0.1), down + 2 * 10**9)
    out = again.begin_tick(down + 2 * 10**9)
    assert "watchdog" not in _kinds(out)
    again.finish_tick(None)
    later = again.begin_tick(down + 10 * 10**9)  # grace (5 s) over for ag-b's robot
    removed = [m for _, m in later if isinstance(m, Event) and m.kind == "removed"]
    assert [m.robot_id for m in removed] == [2]


def test_a_restarted_agent_gets_its_robot_back_where_it_is() -> None:
    core, st = _driven()
    x, y = st.x[0], st.y[0]
    # the same agent name from another process: its robot, not "id 1 is taken"
    reply, out = core.register(
        RegisterRequest(spec=RobotSpecMsg(name="a", id=1), agent="ag-a", request_id="99-1"), 3 * 10**9
    )
    assert reply.ok
    assert reply.robot_id == 1
    assert (reply.spec.x_m, reply.spec.y_m) == pytest.approx((x, y))  # type: ignore[union-attr]
    assert "registered" in _kinds(out)
    assert core.registry.ids == [1, 2]
    # the same process asking for the same id again is refused as before
    dup, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="a", id=1), agent="ag-a", request_id="99-2"), 0)
    assert not dup.ok
    # another agent cannot take it
    other, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="a", id=1), agent="ag-z", request_id="7-1"), 0)
    assert not other.ok


def test_a_resumed_chair_goes_on_as_it_went_until_its_agent_answers() -> None:
    core, st = _driven()
    again = _resumed(core, st, 10**12)
    again.on_alive("agent", "ag-a", True, 10**12)
    core.on_alive("agent", "ag-a", True, 10**12)
    a = _tick(core, 21 * 100 * MS)  # the first world keeps the last command (sticky)
    b = _tick(again, 10**12 + 100 * MS)
    assert b.speed[0] == pytest.approx(a.speed[0], rel=0.02)
    assert b.speed[0] > 0.1
