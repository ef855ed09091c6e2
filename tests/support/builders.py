"""Builders the tests share: walls, random scenes and poses, a world state and its proposal, a
dead-end lab, an agent host on a fake bus."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from iw_zenoh.core.lab import Lab, Scene, Wall, check_wall
from iw_zenoh.messages import (
    LabMsg,
    Proposed,
    RegisterReply,
    RobotSpecMsg,
    SensorReading,
    WorldInfo,
    WorldState,
    encode,
)

if TYPE_CHECKING:
    from iw_zenoh.agent import Agent, AgentHost
    from tests.support.fakes import FakeBus


def box_wall(x0: float, y0: float, x1: float, y1: float, height_m: float = 4.0) -> Wall:
    """An axis-aligned rectangular wall."""
    return Wall(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), height_m)


def random_scene(g: np.random.Generator) -> Scene:
    """A 10 x 10 m lab with up to five random box walls (the sensors' tests against shapely)."""
    walls = []
    for _ in range(g.integers(0, 6)):
        x, y = g.uniform(0.5, 8.5, 2)
        w, h = g.uniform(0.05, 2.0, 2)
        walls.append(box_wall(x, y, min(x + w, 9.9), min(y + h, 9.9)))
    return Scene(Lab("random", 10.0, 10.0, tuple(walls)))


def random_polygon_scene(g: np.random.Generator) -> Scene:
    """A 10 x 10 m lab with up to five random simple polygons as walls, convex or not, listed
    clockwise or counter-clockwise, overlapping one another or not (star-shaped: corners at
    increasing angles around a centre, each at its own distance)."""
    walls = []
    for _ in range(g.integers(0, 6)):
        cx, cy = g.uniform(1.6, 8.4, 2)
        k = int(g.integers(3, 9))
        angles = np.sort(g.uniform(0.0, 2.0 * np.pi, k))
        radii = g.uniform(0.1, 1.5, k)
        corners = [(float(cx + r * np.cos(a)), float(cy + r * np.sin(a))) for a, r in zip(angles, radii, strict=True)]
        if g.random() < 0.5:
            corners.reverse()
        wall = Wall(tuple(corners), 4.0)
        if check_wall(wall.corners, 10.0, 10.0) is None:  # two angles drawn too close: left out
            walls.append(wall)
    return Scene(Lab("random polygons", 10.0, 10.0, tuple(walls)))


def random_poses(g: np.random.Generator, n: int) -> np.ndarray:
    """(n, 3) poses anywhere in :func:`random_scene`'s lab, facing anywhere."""
    return np.column_stack([g.uniform(0.5, 9.5, n), g.uniform(0.5, 9.5, n), g.uniform(-np.pi, np.pi, n)])


def world_state(
    tick: int,
    ids: Sequence[int] = (1,),
    *,
    revision: int = 1,
    x: float | Sequence[float] = 1.0,
    y: float = 1.0,
    heading: float = 0.0,
    collided: bool | Sequence[bool] = False,
    rolled: float = 0.0,
    speed: float = 0.0,
    held: bool = False,
    held_reason: str = "",
) -> WorldState:
    """The world's state of ``tick`` (at 100 ms a tick) for robots ``ids``: every robot alike, each
    scalar given for all of them, ``x`` and ``collided`` also one a robot."""
    n = len(ids)
    xs = [x] * n if isinstance(x, float | int) else list(x)
    hits = [collided] * n if isinstance(collided, bool) else list(collided)
    return WorldState(
        tick=tick,
        sim_time_ns=tick * 100_000_000,
        revision=revision,
        ids=list(ids),
        x=[float(v) for v in xs],
        y=[y] * n,
        heading=[heading] * n,
        collided=hits,
        rolled_left=[rolled] * n,
        rolled_right=[rolled] * n,
        speed=[speed] * n,
        held=held,
        held_reason=held_reason,
    )


def proposal_of(st: WorldState) -> Proposed:
    """The world's proposal whose next poses and distances rolled are those of ``st`` (every robot
    from the origin, active): what commits ``st`` if no robot collides."""
    n = len(st.ids)
    return Proposed(
        tick=st.tick,
        sim_time_ns=st.sim_time_ns,
        revision=st.revision,
        ids=st.ids,
        x=[0.0] * n,
        y=[0.0] * n,
        heading=[0.0] * n,
        next_x=st.x,
        next_y=st.y,
        next_heading=st.heading,
        linear=[0.0] * n,
        active=[True] * n,
        rolled_left=st.rolled_left,
        rolled_right=st.rolled_right,
        tick_wall_ns=st.tick_wall_ns,
    )


DEAD_END = Lab(
    "dead end",
    6.0,
    3.0,
    (box_wall(2.0, 0.0, 6.0, 1.05), box_wall(2.0, 1.95, 6.0, 3.0), box_wall(5.0, 1.05, 6.0, 1.95)),
)  # a 0.9 m corridor from the open end at x = 2 to a wall at x = 5: too narrow to turn the chair in


def bare_reading(tick: int, rid: int = 1, compass_deg: float = 0.0) -> bytes:
    """An encoded reading of a robot with no sensor but its compass (and a GPS at the origin)."""
    return encode(
        SensorReading(
            tick=tick,
            robot_id=rid,
            proximity_ids=[],
            proximity_m=[],
            proximity_legacy=[],
            compass_deg=compass_deg,
            gps=(0, 0, 0),
        )
    )


def agent_host(*agents: Agent, world_tick: int = 50) -> tuple[AgentHost, FakeBus]:
    """An agent host on a fake bus, with ``agents`` registered as robots 1, 2, ... of a world at
    ``world_tick`` (in real time)."""
    from iw_zenoh.agent import AgentHost
    from tests.support.fakes import FakeBus

    bus = FakeBus()
    ids = iter(range(1, len(agents) + 1))

    def answer(key: str, payload: bytes) -> list[bytes]:
        rid = next(ids)
        spec = RobotSpecMsg(name=f"r{rid}", id=rid, x_m=1.0, y_m=float(rid))
        return [encode(RegisterReply(tick=world_tick, ok=True, robot_id=rid, spec=spec))]

    bus.answer = answer
    bus.info = [encode(WorldInfo(tick=world_tick, revision=1, lab=LabMsg(name="l", width=5, height=5), period_ns=1))]
    host = AgentHost(bus, "t", "host")
    for i, agent in enumerate(agents, start=1):
        assert host.add(agent, timeout_s=1.0) == i
    return host, bus
