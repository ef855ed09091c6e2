"""The world's description names the agent driving each robot, so a late joiner (a viewer
started after the registrations) knows it without having seen the ``registered`` events."""

from __future__ import annotations

from iw_zenoh.core.lab import Grid, GridPosition, Lab
from iw_zenoh.messages import RegisterRequest, RobotSpecMsg, WorldInfo, decode, encode
from iw_zenoh.sim.config import WorldConfig
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
