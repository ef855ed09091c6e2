"""The world's description as other roles see it: one revision's scene and robots."""

from __future__ import annotations

from dataclasses import dataclass, field

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.lab import Scene
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import WorldInfo

__all__ = ["ROSTERS_KEPT", "WorldView"]

ROSTERS_KEPT = 8  # rosters whose bodies one view keeps (its own, and a few of states still in flight)


@dataclass(frozen=True, eq=False)
class WorldView:
    """What one revision of the world looks like: its scene and its robots in array order."""

    info: WorldInfo
    scene: Scene
    specs: dict[int, RobotSpec]
    _bodies: dict[tuple[int, ...], Bodies] = field(default_factory=dict)

    def bodies_for(self, ids: list[int]) -> Bodies:
        """Body arrays for these robots, in this order (built once per roster)."""
        key = tuple(ids)
        got = self._bodies.get(key)
        if got is None:
            if len(self._bodies) >= ROSTERS_KEPT:  # states of older revisions, each a roster of its own
                self._bodies.clear()
            got = self._bodies[key] = Bodies.from_specs([self.specs[i] for i in ids])
        return got
