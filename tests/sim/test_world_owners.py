"""A secured world registers for an agent only the robots the policy gives it."""

from __future__ import annotations

import pytest

from iw_zenoh.core.lab import Grid, GridPosition, Lab
from iw_zenoh.messages import RegisterRequest, RobotSpecMsg
from iw_zenoh.sim.config import WorldConfig
from iw_zenoh.sim.world import WorldCore

OWNERS: dict[str, tuple[int, ...] | None] = {"alice": (2, 3), "bridge": None}


def _core(owners: dict[str, tuple[int, ...] | None] | None = OWNERS) -> WorldCore:
    grid = Grid(tuple(GridPosition(2 + 3 * i, 5, 0) for i in range(4)))
    return WorldCore(WorldConfig(sim="t", owners=owners), Lab("t", 20.0, 10.0, ()), grid)


def _ask(core: WorldCore, agent: str, robot_id: int = 0, name: str = "c") -> tuple[bool, int, str]:
    reply, _ = core.register(RegisterRequest(spec=RobotSpecMsg(name=name, id=robot_id), agent=agent), 0)
    return reply.ok, reply.robot_id, reply.reason


def test_an_agent_gets_its_own_robot_when_it_asks_for_it() -> None:
    assert _ask(_core(), "alice", 3)[:2] == (True, 3)


def test_an_agent_asking_for_any_robot_gets_the_first_of_its_own() -> None:
    core = _core()
    assert _ask(core, "alice", 0, "a")[:2] == (True, 2)
    assert _ask(core, "alice", 0, "b")[:2] == (True, 3)
    ok, _, reason = _ask(core, "alice", 0, "c")
    assert not ok
    assert "every robot" in reason


@pytest.mark.parametrize(("agent", "robot", "why"), [("alice", 1, "not agent 'alice''s"), ("mallory", 0, "mallory")])
def test_a_robot_not_given_to_the_agent_is_refused_with_the_reason(agent: str, robot: int, why: str) -> None:
    ok, _, reason = _ask(_core(), agent, robot)
    assert not ok
    assert why in reason


def test_a_bridge_registers_any_robot() -> None:
    assert _ask(_core(), "bridge", 4)[:2] == (True, 4)


def test_an_open_world_registers_any_robot_for_anyone() -> None:
    assert _ask(_core(None), "mallory", 1)[:2] == (True, 1)


def test_a_bridge_cannot_take_a_robot_the_policy_gives_an_agent() -> None:
    core = _core()
    ok, _, reason = _ask(core, "bridge", 2)
    assert not ok
    assert "agent 'alice''s by the policy" in reason
    # asking for any robot, it gets the first id neither taken nor an agent's
    assert _ask(core, "bridge", 0, "a")[:2] == (True, 1)
    assert _ask(core, "bridge", 0, "b")[:2] == (True, 4)
    # and the agent still gets its own
    assert _ask(core, "alice", 0, "c")[:2] == (True, 2)
