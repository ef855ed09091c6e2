"""The world's description names the agent driving each robot, so a late joiner (a viewer
started after the registrations) knows it without having seen the ``registered`` events."""

from __future__ import annotations

from iw_zenoh.core.lab import Grid, GridPosition, Lab
from iw_zenoh.messages import Event, EventKind, RegisterRequest, RobotSpecMsg, WorldInfo, decode, encode
from iw_zenoh.sim.config import MS, WorldConfig
from iw_zenoh.sim.world import WorldCore


def test_the_description_names_each_robots_agent_in_the_order_of_its_robots() -> None:
    grid = Grid((GridPosition(2, 5, 0), GridPosition(5, 5, 0), GridPosition(8, 5, 0)))
    core = WorldCore(WorldConfig(sim="t"), Lab("t", 20.0, 10.0), grid)
    for name, agent in (("a", "host-a"), ("b", ""), ("c", "host-c")):
        reply, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name=name), agent=agent), 0)
        assert reply.ok, reply.reason
    info = decode(encode(core.info()), WorldInfo)
    assert [r.name for r in info.robots] == ["a", "b", "c"]
    assert info.agents == ["host-a", "", "host-c"]


def _open_world(grace_ms: float = 1000.0) -> WorldCore:
    return WorldCore(WorldConfig(sim="t", grace_ms=grace_ms), Lab("t", 40.0, 40.0), Grid(()))


def test_robots_of_agents_whose_liveliness_never_appears_are_removed_after_the_grace() -> None:
    core = _open_world()
    core.on_alive("agent", "real", True, 0)
    assert core.register(RegisterRequest(spec=RobotSpecMsg(name="r", x_m=1.0, y_m=1.0), agent="real"), 0)[0].ok
    late = RegisterRequest(spec=RobotSpecMsg(name="late", x_m=1.0, y_m=3.0), agent="late")
    assert core.register(late, 0)[0].ok  # its token comes after its registration: it stays
    for k in range(200):  # a flood: each for an agent that does not exist
        ghost = RegisterRequest(
            spec=RobotSpecMsg(name=f"g{k}", x_m=3.0 + 2 * (k % 15), y_m=5.0 + 2 * (k // 15)), agent=f"ghost-{k}"
        )
        assert core.register(ghost, 10 * MS)[0].ok
    core.on_alive("agent", "late", True, 500 * MS)
    assert len(core.registry.entries) == 202
    assert core.overdue(1000 * MS) == []  # within the grace
    lost = core.overdue(1011 * MS)
    assert len(lost) == 200
    assert {m.kind for _, m in lost if isinstance(m, Event)} == {EventKind.AGENT_LOST}
    assert "liveliness never appeared" in next(m.reason for _, m in lost if isinstance(m, Event))
    assert core.agents_alive == {"real", "late"}
    assert core.expected(core.tick + 1) == [1, 2]  # lock-step waits no more for a ghost
    out = core.begin_tick(1011 * MS)
    assert [e.name for e in core.registry.specs()] == ["r", "late"]  # 0 ghosts
    assert sum(1 for _, m in out if isinstance(m, Event) and m.kind == EventKind.REMOVED) == 200


def test_an_agent_stopped_past_its_lease_gets_its_own_robot_back_from_the_same_process() -> None:
    core = _open_world(grace_ms=5000.0)
    core.on_alive("agent", "host", True, 0)
    ask = RegisterRequest(spec=RobotSpecMsg(name="chair", x_m=5.0, y_m=5.0), agent="host", request_id="4242-1")
    first, _ = core.register(ask, 0)
    assert first.ok
    core.on_alive("agent", "host", False, 1000 * MS)  # SIGSTOP past its lease: its token is gone
    core.on_alive("agent", "host", True, 4000 * MS)  # SIGCONT: its session is back
    again = RegisterRequest(spec=RobotSpecMsg(name="chair", x_m=5.0, y_m=5.0), agent="host", request_id="4242-2")
    reply, _ = core.register(again, 4000 * MS)
    assert reply.ok, reply.reason  # was: 'start (5, 5) puts the body on robot 1': its own old body
    assert reply.robot_id == first.robot_id
    assert core.registry.entries[first.robot_id].lost_ns is None


def test_the_scenario_s_ids_are_its_agents_not_a_wanderer_s() -> None:
    grid = Grid((GridPosition(2, 5, 0), GridPosition(5, 5, 0), GridPosition(8, 5, 0)))
    core = WorldCore(WorldConfig(sim="t", reserved={"driver": (1,)}), Lab("t", 20.0, 10.0), grid)
    wanderer, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="w"), agent="wanderer"), 0)
    assert wanderer.ok
    assert wanderer.robot_id == 2  # was 1: the scenario's robot 1 then could not register
    taken, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="w2", id=1), agent="wanderer"), 0)
    assert not taken.ok
    assert "robot 1 is the scenario's, for agent 'driver'" in taken.reason
    mine, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="d", id=1), agent="driver"), 0)
    assert mine.ok, mine.reason
    assert mine.robot_id == 1


def test_an_id_reserved_for_two_names_is_either_s() -> None:
    cfg = WorldConfig(sim="t", reserved={"bridge-serial": (1,), "agent-1-wheelchair": (1,), "other": (2,)})
    core = WorldCore(cfg, Lab("t", 20.0, 10.0), Grid((GridPosition(2, 5, 0), GridPosition(5, 5, 0))))
    reply, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name="chair", id=1), agent="bridge-serial"), 0)
    assert reply.ok, reply.reason  # the chair's bridge registers the robot its agent attaches to
