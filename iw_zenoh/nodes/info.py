"""The world's description as other nodes see it (a :class:`~iw_zenoh.sim.view.WorldView`):
fetched from ``world/info`` whenever a batched message names a revision this node has not seen
(a robot registered or left, an obstacle moved)."""

from __future__ import annotations

import logging

from iw_zenoh import keys
from iw_zenoh.bus import Bus
from iw_zenoh.convert import lab_from_msg, spec_from_msg
from iw_zenoh.core.lab import Scene
from iw_zenoh.errors import IwError
from iw_zenoh.messages import WorldInfo, decode
from iw_zenoh.sim.view import WorldView

__all__ = ["InfoCache"]

logger = logging.getLogger(__name__)


class InfoCache:
    """Keeps the latest world view, asking the world again when the revision changes.

    Args:
        bus: The bus.
        sim: Simulation name.
        timeout_s: How long one query may take.
    """

    def __init__(self, bus: Bus, sim: str, timeout_s: float = 2.0) -> None:
        self.bus = bus
        self.sim = sim
        self.timeout_s = timeout_s
        self.view: WorldView | None = None
        self._scene_key: tuple[object, ...] | None = None
        self._scene: Scene | None = None

    def get(self, revision: int) -> WorldView | None:
        """The view at ``revision`` (or newer); None when the world does not answer."""
        if self.view is not None and self.view.info.revision >= revision:
            return self.view
        for data in self.bus.query(keys.info(self.sim), timeout_s=self.timeout_s):
            try:
                info = decode(data, WorldInfo)
                lab = lab_from_msg(info.lab)
                key = (info.lab.name, len(lab.walls), tuple(w.corners for w in lab.walls))
                specs = {s.id: spec_from_msg(s) for s in info.robots}
                if self._scene is None or key != self._scene_key:
                    self._scene = Scene(lab)
                    self._scene_key = key
            except (IwError, ValueError) as e:  # not the world's: a robot or a wall it cannot have
                logger.warning("world/info answer refused: %s", e)
                continue
            self.view = WorldView(info, self._scene, specs)
            return self.view if info.revision >= revision else None
        return None
