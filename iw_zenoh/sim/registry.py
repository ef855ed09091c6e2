"""The world's roster: who is registered, with which spec, driven by which agent, commanding
what; and the rules that accept or refuse a registration."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.lab import Grid, Scene
from iw_zenoh.core.spec import RobotSpec, RobotType

__all__ = ["Entry", "Registry", "Refused"]


class Refused(Exception):
    """A registration the world refuses; the message is the reason sent back."""


@dataclass
class Entry:
    """One registered robot.

    Attributes:
        spec: The accepted spec, with its id and start pose.
        agent: Liveliness name of the agent process driving it ("" for none).
        cmd: Last commanded powers (left, right).
        last_action_ns: Monotonic time of its last actions (or of its registration).
        last_action_tick: The sensors tick its last actions answered (-1: none yet).
        watchdog: True while its motors are zeroed for want of fresh actions.
        lost_ns: When its agent was lost (for removal after the grace period), or None.
        report: Last reported pose of a Real robot (x, y, heading rad), or None.
    """

    spec: RobotSpec
    agent: str = ""
    cmd: tuple[float, float] = (0.0, 0.0)
    last_action_ns: int = 0
    last_action_tick: int = -1
    watchdog: bool = False
    lost_ns: int | None = None
    report: tuple[float, float, float] | None = None
    leds: dict[str, bool] = field(default_factory=dict)


class Registry:
    """Robots by id, in registration order (the order of every batched array)."""

    def __init__(self, scene: Scene, grid: Grid) -> None:
        self.scene = scene
        self.grid = grid
        self.entries: dict[int, Entry] = {}

    @property
    def ids(self) -> list[int]:
        """Robot ids in array order."""
        return list(self.entries)

    def specs(self) -> list[RobotSpec]:
        """Accepted specs in array order."""
        return [e.spec for e in self.entries.values()]

    def _free_id(self) -> int:
        for k in range(1, len(self.grid.positions) + 1):
            if k not in self.entries:
                return k
        raise Refused(
            f"the grid is full: all {len(self.grid.positions)} start positions are taken; "
            "give X and Y, or remove a robot"
        )

    def place(self, spec: RobotSpec, pose: dict[int, tuple[float, float, float]]) -> RobotSpec:
        """Chooses the id and start pose of a new robot, or refuses it.

        Args:
            spec: The requested spec.
            pose: Current poses of the registered robots (x, y, heading rad) by id.

        Returns:
            The spec with id and pose set.

        Raises:
            Refused: Duplicate id, full grid, id beyond the grid without a pose, or a start pose
                outside the lab, inside a wall or on another robot.
        """
        rid = spec.id
        if rid == 0:
            rid = self._free_id() if spec.x_m is None else max([0, len(self.grid.positions), *self.entries]) + 1
        if rid in self.entries:
            raise Refused(
                f"id {rid} is taken by {self.entries[rid].spec.name!r}; ask for another id or 0 for the first free one"
            )
        if spec.x_m is None or spec.y_m is None:
            if rid > len(self.grid.positions):
                raise Refused(f"id {rid} is beyond the grid's {len(self.grid.positions)} start positions; give X and Y")
            g = self.grid.positions[rid - 1]
            x, y, d = g.x, g.y, g.dir_deg
        else:
            x, y = spec.x_m, spec.y_m
            d = spec.dir_deg if spec.dir_deg is not None else 0.0
        if spec.dir_deg is not None:
            d = spec.dir_deg
        placed = spec.placed(rid, x, y, d)
        lab = self.scene.lab
        if not (0.0 < x < lab.width_m and 0.0 < y < lab.height_m):
            raise Refused(f"start ({x:g}, {y:g}) is outside the lab ({lab.width_m:g} x {lab.height_m:g})")
        body = Bodies.from_specs([placed])
        poly = shapely.polygons(body.world_outline(np.array([[x, y, np.radians(d)]])))[0]
        if placed.type != RobotType.DOOR:
            hit = self.scene.wall_tree.query(poly, predicate="intersects")
            if len(hit):
                raise Refused(f"start ({x:g}, {y:g}) puts the body on wall {int(hit[0])}; choose a free place")
        others = list(pose.items())
        if others:
            ob = Bodies.from_specs([self.entries[i].spec for i, _ in others])
            polys = shapely.polygons(ob.world_outline(np.array([p for _, p in others])))
            touching = np.flatnonzero(shapely.intersects(polys, poly))
            if len(touching):
                other = others[int(touching[0])][0]
                raise Refused(f"start ({x:g}, {y:g}) puts the body on robot {other}; choose a free place")
        return placed

    def add(self, spec: RobotSpec, agent: str, now_ns: int) -> Entry:
        """Adds an accepted robot."""
        e = Entry(spec=spec, agent=agent, last_action_ns=now_ns)
        self.entries[spec.id] = e
        return e

    def remove(self, robot_id: int) -> Entry | None:
        """Removes a robot; returns it, or None if there was none."""
        return self.entries.pop(robot_id, None)
