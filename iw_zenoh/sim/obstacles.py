"""Rectangular obstacles added, moved and removed while the world runs, and the lab they make
with the map's own walls."""

from __future__ import annotations

import math

import msgspec

from iw_zenoh.core.lab import Lab, Wall, check_wall
from iw_zenoh.messages import Obstacle

__all__ = ["MAX_OBSTACLES", "NAME_MAX", "Obstacles"]

NAME_MAX = 64  # characters of an obstacle's name: a label on a page and a key in the world's table
MAX_OBSTACLES = 1024  # at once: each is a wall every tick's collisions and readings look at


class Obstacles:
    """The live obstacles, by name, over a map.

    Args:
        lab: The map without obstacles.
    """

    def __init__(self, lab: Lab) -> None:
        self.base_lab = lab
        self.by_name: dict[str, Obstacle] = {}

    def apply(self, command: str, ob: Obstacle) -> str:
        """Adds, moves or removes one obstacle.

        Args:
            command: ``add_obstacle``, ``move_obstacle`` or ``remove_obstacle``.
            ob: The obstacle (only its name counts for a removal); corners in any order.

        Returns:
            Why it was not done (nothing changed), or "" when done.
        """
        if command == "remove_obstacle":
            if self.by_name.pop(ob.name, None) is None:
                return f"no obstacle named {ob.name!r}"
            return ""
        if not 1 <= len(ob.name) <= NAME_MAX:
            return f"an obstacle's name is 1 to {NAME_MAX} characters, got {len(ob.name)}"
        if not (math.isfinite(ob.height) and ob.height > 0):
            return f"obstacle {ob.name!r}: its height must be a positive number of metres, got {ob.height:g}"
        x0, x1 = sorted((ob.x0, ob.x1))
        y0, y1 = sorted((ob.y0, ob.y1))
        corners = ((x0, y0), (x1, y0), (x1, y1), (x0, y1))
        why = check_wall(corners, self.base_lab.width_m, self.base_lab.height_m)
        if why:
            return f"obstacle {ob.name!r}: {why}"
        if command == "move_obstacle" and ob.name not in self.by_name:
            return f"no obstacle named {ob.name!r} to move"
        if ob.name not in self.by_name and len(self.by_name) >= MAX_OBSTACLES:
            return f"obstacle {ob.name!r}: the world holds {MAX_OBSTACLES} obstacles already, the most it takes"
        self.by_name[ob.name] = msgspec.structs.replace(ob, x0=x0, y0=y0, x1=x1, y1=y1)
        return ""

    def lab(self) -> Lab:
        """The map with every obstacle as a wall after its own (in the order they were added)."""
        walls = tuple(
            Wall(((o.x0, o.y0), (o.x1, o.y0), (o.x1, o.y1), (o.x0, o.y1)), o.height) for o in self.by_name.values()
        )
        return self.base_lab.with_walls(walls)
