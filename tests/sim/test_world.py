from __future__ import annotations

import pytest

from iw_zenoh.messages import (
    Actions,
    Control,
    Event,
    Obstacle,
    PoseReport,
    RegisterRequest,
    RobotSpecMsg,
    Verdict,
    WorldState,
)
from iw_zenoh.sim import registry
from iw_zenoh.sim.config import MS
from iw_zenoh.sim.registry import MAX_ROBOT_ID
from tests.support.sim_core import event_kinds as _kinds
from tests.support.sim_core import step as _tick
from tests.support.sim_core import world_core as _core


def test_registration_takes_the_first_free_grid_slot_and_announces_it() -> None:
    core = _core()
    reply, out = core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
    assert reply.ok
    assert reply.robot_id == 1
    assert (reply.spec.x_m, reply.spec.y_m) == (2.0, 5.0)  # type: ignore[union-attr]
    assert "registered" in _kinds(out)


@pytest.mark.parametrize(
    ("spec", "reason"),
    [
        (RobotSpecMsg(name="b", id=1), "id 1 is taken"),
        (RobotSpecMsg(name="c", id=3), "beyond the grid"),
        (RobotSpecMsg(name="d", x_m=9.5, y_m=1.0), "wall"),
        (RobotSpecMsg(name="e", x_m=2.5, y_m=5.0), "robot 1"),
        (RobotSpecMsg(name="f", x_m=25.0, y_m=5.0), "outside the lab"),
        (RobotSpecMsg(name="g", max_speed_mps=-1.0), "max_speed"),
        (RobotSpecMsg(name="h", max_speed_mps=1e12), "max_speed_mps: must be in ]0;100], got 1000000000000.0"),
    ],
)
def test_refusals_say_why(spec: RobotSpecMsg, reason: str) -> None:
    core = _core()
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
    reply, out = core.register(RegisterRequest(spec=spec), 0)
    assert not reply.ok
    assert reason in reply.reason
    assert "refused" in _kinds(out)


def test_the_fastest_chair_at_full_power_keeps_its_poses_within_the_wire_s_limits() -> None:
    core = _core()
    reply, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="a", max_speed_mps=100.0)), 0)
    assert reply.ok
    core.collision_alive.add("c")
    for k in range(20):  # full power on both wheels for 20 ticks: each proposal must encode
        core.on_actions(Actions(tick=core.tick + 1, robot_id=reply.robot_id, left=0.15, right=0.15), k * MS)
        _tick(core, k * 100 * MS)


def test_actions_move_the_chair_at_the_next_tick_and_stale_ones_trip_the_watchdog() -> None:
    core = _core(action_timeout_ms=500.0)
    core.collision_alive.add("c")
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
    core.on_actions(Actions(robot_id=1, left=0.15, right=0.15), 0)
    s = _tick(core, 100 * MS)
    assert s.x[0] > 2.0
    out = core.begin_tick(700 * MS)  # 700 ms after the last actions
    assert "watchdog" in _kinds(out)
    assert core.state.cmd.tolist() == [[0.0, 0.0]]


@pytest.mark.parametrize(
    ("kw", "kept"),
    [
        ({"profile": "ciberrato"}, True),  # the legacy rule: a silent robot's motors keep its last power
        ({"profile": "ciberrato", "silence": "stop"}, False),
        ({"profile": "native", "silence": "keep"}, True),  # any profile may opt in
        ({"profile": "native"}, False),
    ],
)
def test_a_silent_robot_keeps_its_last_command_where_silence_keeps_it(kw: dict[str, str], kept: bool) -> None:
    core = _core(action_timeout_ms=500.0, **kw)
    core.collision_alive.add("c")
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
    core.on_actions(Actions(robot_id=1, left=0.1, right=0.1), 0)
    _tick(core, 50 * MS)
    out = core.begin_tick(60_000 * MS)  # a minute of silence
    assert ("watchdog" in _kinds(out)) is not kept
    assert core.state.cmd.tolist() == ([[0.1, 0.1]] if kept else [[0.0, 0.0]])


def test_a_pause_is_not_silence_resume_never_trips_the_watchdog() -> None:
    core = _core(action_timeout_ms=500.0)
    core.collision_alive.add("c")
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
    core.on_actions(Actions(robot_id=1, left=0.15, right=0.15), 0)
    _tick(core, 100 * MS)
    core.on_control(Control(command="pause"))
    core.on_control(Control(command="start"))
    out = core.begin_tick(10_000 * MS)  # ten seconds paused, 100 ms of silence while running
    assert "watchdog" not in _kinds(out)
    assert core.state.cmd.tolist() == [[0.15, 0.15]]


def test_silence_before_a_pause_still_counts_after_it() -> None:
    core = _core(action_timeout_ms=500.0)
    core.collision_alive.add("c")
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
    core.on_actions(Actions(robot_id=1, left=0.15, right=0.15), 0)
    _tick(core, 400 * MS)
    core.on_control(Control(command="pause"))
    core.on_control(Control(command="step", steps=2))
    _tick(core, 10_000 * MS)  # 400 ms silent before the pause: 100 ms left
    out = core.begin_tick(10_200 * MS)
    assert "watchdog" in _kinds(out)


def test_a_world_started_late_does_not_count_the_wait_as_silence() -> None:
    core = _core(action_timeout_ms=500.0, start_paused=True)
    core.collision_alive.add("c")
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
    core.on_actions(Actions(robot_id=1, left=0.15, right=0.15), 0)
    core.on_control(Control(command="start"))
    out = core.begin_tick(5_000 * MS)
    assert "watchdog" not in _kinds(out)


def test_lockstep_a_robot_that_answered_the_last_tick_is_on_time_however_long_the_tick_took() -> None:
    core = _core(mode="lockstep", action_timeout_ms=500.0)
    core.collision_alive.add("c")
    core.register(RegisterRequest(spec=RobotSpecMsg(name="door"), agent="d"), 0)
    core.register(RegisterRequest(spec=RobotSpecMsg(name="slow"), agent="s"), 0)
    s = _tick(core, 100 * MS)
    core.on_actions(Actions(tick=s.tick, robot_id=1, left=0.15, right=0.15), 100 * MS)
    core.on_actions(Actions(tick=s.tick, robot_id=2, left=0.1, right=0.1), 3000 * MS)  # planned for 3 s
    out = core.begin_tick(3000 * MS)
    assert "watchdog" not in _kinds(out)
    assert core.state.cmd.tolist() == [[0.15, 0.15], [0.1, 0.1]]


def test_a_lost_agent_zeroes_its_robots_at_once_and_removes_them_after_the_grace() -> None:
    core = _core(grace_ms=1000.0)
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a"), agent="ag"), 0)
    core.on_alive("agent", "ag", True, 0)
    core.on_actions(Actions(robot_id=1, left=0.1, right=0.1), 0)
    assert "agent-lost" in _kinds(core.on_alive("agent", "ag", False, 10 * MS))
    core.begin_tick(20 * MS)
    assert core.state.cmd.tolist() == [[0.0, 0.0]]
    out = core.begin_tick(1200 * MS)
    assert "removed" in _kinds(out)
    assert core.registry.ids == []


def test_without_a_verdict_every_robot_is_held_and_the_world_says_why() -> None:
    core = _core()
    core.begin_tick(0)
    assert "holding" not in _kinds(core.finish_tick(None))  # nobody to hold yet
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
    core.on_actions(Actions(robot_id=1, left=0.15, right=0.15), 0)
    core.begin_tick(0)
    out = core.finish_tick(None)
    assert "holding" in _kinds(out)
    st = next(m for _, m in out if isinstance(m, WorldState))
    assert st.held
    assert st.x == [2.0]
    core.collision_alive.add("c")
    core.begin_tick(MS)
    out = core.finish_tick(Verdict(tick=3, revision=core.revision, ids=[1], collided=[False]))
    assert "resumed" in _kinds(out)


def test_a_verdict_for_another_tick_or_roster_is_not_taken() -> None:
    core = _core()
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
    core.begin_tick(0)
    assert not core.verdict_ok(Verdict(tick=5, revision=core.revision, ids=[1], collided=[False]))
    assert not core.verdict_ok(Verdict(tick=1, revision=core.revision + 1, ids=[1], collided=[False]))
    assert core.verdict_ok(Verdict(tick=1, revision=core.revision, ids=[1], collided=[False]))


def test_lockstep_waits_only_for_live_agents_that_have_not_answered() -> None:
    core = _core(mode="lockstep")
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a"), agent="ag"), 0)
    core.register(RegisterRequest(spec=RobotSpecMsg(name="b"), agent="gone"), 0)
    core.on_alive("agent", "ag", True, 0)
    core.on_alive("agent", "gone", False, 0)
    assert core.expected(1) == [1]
    core.on_actions(Actions(tick=1, robot_id=1), 0)
    assert core.expected(1) == []


def test_lockstep_does_not_step_robots_while_no_sensors_process_is_alive() -> None:
    # without readings no agent can answer: a first tick published before the sensors process
    # subscribed was waited out as a laggard (a sensors process compiling its kernel joins late)
    core = _core(mode="lockstep")
    assert core.due()  # nothing to wait for without robots
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a"), agent="ag"), 0)
    core.on_alive("collision", "collision", True, 0)
    assert not core.due()
    assert _kinds(core.on_alive("sensors", "sensors-1-1", True, 0)) == []
    assert core.due()
    assert _kinds(core.on_alive("sensors", "sensors-1-1", False, 0)) == ["sensors-lost"]
    assert not core.due()
    realtime = _core()
    realtime.register(RegisterRequest(spec=RobotSpecMsg(name="a"), agent="ag"), 0)
    assert realtime.due()  # real time never waits for anybody
    assert _kinds(realtime.on_alive("sensors", "sensors-1-1", False, 0)) == []


def test_lockstep_does_not_step_robots_while_no_collision_process_is_alive() -> None:
    # a tick without a verdict holds every robot: stepped while the collision process was still
    # starting, a run's first ticks depended on when it joined (a two-host run moved 0.06 m, not 0.3)
    core = _core(mode="lockstep")
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a"), agent="ag"), 0)
    core.on_alive("sensors", "sensors-1-1", True, 0)
    assert not core.due()
    assert _kinds(core.on_alive("collision", "collision", True, 0)) == []
    assert core.due()
    assert _kinds(core.on_alive("collision", "collision", False, 0)) == ["holding"]
    assert not core.due()
    core.on_alive("collision", "collision-again", True, 0)
    assert core.due()
    core.begin_tick(0)
    out = core.finish_tick(Verdict(tick=1, revision=core.revision, ids=[1], collided=[False]))
    assert "resumed" in _kinds(out)
    realtime = _core()
    realtime.register(RegisterRequest(spec=RobotSpecMsg(name="a"), agent="ag"), 0)
    assert realtime.due()  # real time holds robots and goes on ticking instead
    assert _kinds(realtime.on_alive("collision", "collision", False, 0)) == []


def test_lockstep_waits_for_a_new_robot_from_its_first_readings_before_its_agent_token_arrives() -> None:
    # the token is declared before the agent registers but may reach the world later: a world
    # that waited only for agents it had seen alive ran its first ticks without the new robot,
    # differently each run
    core = _core(mode="lockstep")
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a"), agent="ag"), 0)
    assert core.expected(core.tick) == []  # it has no readings of the tick it registered in
    assert core.expected(core.tick + 1) == [1]
    assert core.waiting(core.tick + 1)
    core.on_actions(Actions(tick=core.tick + 1, robot_id=1), 0)
    assert not core.waiting(core.tick + 1)


def test_lockstep_a_real_robot_answers_with_its_pose_report_not_its_actions() -> None:
    core = _core(mode="lockstep")
    core.register(RegisterRequest(spec=RobotSpecMsg(name="r", type="Real"), agent="ag"), 0)
    n = core.tick + 1
    core.on_actions(Actions(tick=n, robot_id=1), 0)  # arrived first: the pose is not here yet
    assert core.waiting(n)
    core.on_pose_report(PoseReport(tick=n, robot_id=1, x=3.0, y=4.0, dir_deg=0.0), 0)
    assert not core.waiting(n)


def test_obstacles_are_added_moved_and_refused_outside_the_lab() -> None:
    core = _core()
    rev = core.revision
    out = core.on_control(Control(command="add_obstacle", obstacle=Obstacle(name="A", x0=12, y0=4, x1=13, y1=5)))
    assert "obstacle" in _kinds(out)
    assert core.revision == rev + 1
    assert len(core.scene.lab.walls) == 2
    out = core.on_control(Control(command="add_obstacle", obstacle=Obstacle(name="B", x0=19, y0=4, x1=23, y1=5)))
    assert "bad-control" in _kinds(out)
    core.on_control(Control(command="remove_obstacle", obstacle=Obstacle(name="A", x0=0, y0=0, x1=0, y1=0)))
    assert len(core.scene.lab.walls) == 1


@pytest.mark.parametrize(
    ("ob", "says"),
    [
        (Obstacle(name="A", x0=12, y0=4, x1=13, y1=5, height=-1.0), "height must be a positive number"),
        (Obstacle(name="A", x0=12, y0=4, x1=13, y1=5, height=float("nan")), "height must be a positive number"),
        (Obstacle(name="", x0=12, y0=4, x1=13, y1=5), "name is 1 to 64 characters, got 0"),
        (Obstacle(name="x" * 5000, x0=12, y0=4, x1=13, y1=5), "name is 1 to 64 characters, got 5000"),
    ],
)
def test_an_obstacle_without_a_height_or_a_name_is_refused_with_the_reason(ob: Obstacle, says: str) -> None:
    core = _core()
    rev = core.revision
    for command in ("add_obstacle", "move_obstacle"):
        out = core.on_control(Control(command=command, obstacle=ob))
        assert _kinds(out) == ["bad-control"]
        assert [says in m.reason for _, m in out if isinstance(m, Event)] == [True]
    assert core.revision == rev


def test_pause_step_and_start() -> None:
    core = _core(expect=0)
    core.on_control(Control(command="pause"))
    assert not core.due()
    core.on_control(Control(command="step", steps=2))
    assert core.due()
    core.collision_alive.add("c")
    _tick(core, 0)
    _tick(core, MS)
    assert not core.due()
    core.on_control(Control(command="start"))
    assert core.due()


def test_the_first_tick_waits_for_the_expected_roster() -> None:
    core = _core(expect=2)
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
    assert not core.due()
    core.register(RegisterRequest(spec=RobotSpecMsg(name="b")), 0)
    assert core.due()


def test_a_registration_asked_again_gets_its_first_answer() -> None:
    core = _core()
    req = RegisterRequest(spec=RobotSpecMsg(name="a"), agent="ag", request_id="r1")
    first, _ = core.register(req, 0)
    again, out = core.register(req, 0)
    assert again == first
    assert out == []
    assert core.registry.ids == [1]


def test_robots_registered_between_ticks_are_built_once_and_placed_apart(monkeypatch: pytest.MonkeyPatch) -> None:
    from iw_zenoh.sim import world as world_core

    core = _core()
    builds: list[int] = []  # sizes of roster builds (placing one newcomer builds just its body)
    real = world_core.Bodies.from_specs

    def counted(specs: list[object]) -> object:
        if len(specs) > 1:
            builds.append(len(specs))
        return real(specs)  # type: ignore[arg-type]

    monkeypatch.setattr(world_core.Bodies, "from_specs", staticmethod(counted))
    assert core.register(RegisterRequest(spec=RobotSpecMsg(name="a", x_m=4.0, y_m=8.0)), 0)[0].ok
    # the second asks for the first one's place before any tick: still refused (it is there)
    on_it = core.register(RegisterRequest(spec=RobotSpecMsg(name="b", x_m=4.2, y_m=8.0)), 0)[0]
    assert not on_it.ok
    assert "robot" in on_it.reason
    assert core.register(RegisterRequest(spec=RobotSpecMsg(name="c", x_m=7.0, y_m=8.0)), 0)[0].ok
    assert builds == []  # nothing rebuilt per registration
    st = _tick(core, 100 * MS)
    assert builds == [2]  # once, when the tick began
    assert sorted(zip(st.ids, st.x, st.y, strict=True)) == [(3, 4.0, 8.0), (4, 7.0, 8.0)]
    assert core.info().revision == st.revision


def test_removing_a_robot_the_world_does_not_have_is_refused_with_its_id() -> None:
    core = _core()
    core.register(RegisterRequest(spec=RobotSpecMsg(name="a")), 0)
    out = core.on_control(Control(command="remove", robot_id=7))
    assert _kinds(out) == ["bad-control"]
    ev = next(m for _, m in out if isinstance(m, Event))
    assert ev.robot_id == 7
    assert "no robot 7" in ev.reason
    assert _kinds(core.on_control(Control(command="remove", robot_id=1))) == ["removed"]


def test_the_leaves_of_a_revolving_door_are_placed_on_one_hub_and_a_chair_is_not() -> None:
    core = _core()
    for i, deg in enumerate((0.0, 120.0, -120.0)):
        leaf = RobotSpecMsg(
            name=f"leaf{i}", type="Door", width_m=1.6, height_m=0.1, com=0.98, x_m=15.0, y_m=5.0, dir_deg=deg
        )
        reply, _ = core.register(RegisterRequest(spec=leaf), 0)
        assert reply.ok, reply.reason  # a door may stand on another door
    reply, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="chair", x_m=15.5, y_m=5.0)), 0)
    assert not reply.ok
    assert "robot" in reply.reason


def test_the_largest_id_then_id_0_overflows_nothing_and_ids_past_the_bound_are_refused() -> None:
    core = _core()
    huge, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="huge", id=2**63 - 1, x_m=12.0, y_m=5.0)), 0)
    assert not huge.ok
    assert f"beyond the largest robot id, {MAX_ROBOT_ID}" in huge.reason
    top, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="top", id=MAX_ROBOT_ID, x_m=12.0, y_m=5.0)), 0)
    assert top.ok  # the largest id there is: the next robot placed by its pose takes the first free one
    any_id, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="any", x_m=15.0, y_m=5.0)), 0)
    assert any_id.ok, any_id.reason
    assert any_id.robot_id == 3  # past the grid's two
    st = _tick(core, 0)  # overflowed in registry.py (max + 1) and core/bodies.py (int64)
    assert st.ids == [MAX_ROBOT_ID, 3]


def test_a_world_holds_a_bounded_number_of_robots_per_agent(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(registry, "MAX_ROBOTS_PER_AGENT", 2)
    core = _core()
    for k in range(2):
        reply, _ = core.register(
            RegisterRequest(spec=RobotSpecMsg(name=f"r{k}", x_m=12.0 + 2 * k, y_m=5.0), agent="a"), 0
        )
        assert reply.ok, reply.reason
    reply, out = core.register(RegisterRequest(spec=RobotSpecMsg(name="r2", x_m=17.0, y_m=5.0), agent="a"), 0)
    assert not reply.ok
    assert "agent 'a' has 2 robots, the most one agent may register" in reply.reason
    assert "refused" in _kinds(out)
    other, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="b", x_m=17.0, y_m=5.0), agent="b"), 0)
    assert other.ok  # another agent is not refused for it
