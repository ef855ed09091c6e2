"""The world's description as other nodes see it (a :class:`~iw_zenoh.sim.view.WorldView`):
fetched from ``world/info`` whenever a batched message names a revision this node has not seen
(a robot registered or left, an obstacle moved), or taken as the world publishes it."""

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
        self.why = ""  # why the last get found no view (the nodes' warning says it)
        self._answered: tuple[int, ...] = ()  # revisions of the last answers when more than one (logged once)

    def get(self, revision: int) -> WorldView | None:
        """The view at ``revision`` (or newer); None when the world does not answer.

        A revision older than the view's is a late message, or a world started afresh (by hand,
        its revisions from 1 again): the world is asked, and a view older than the one kept is
        taken as the new world's, else the one kept serves.
        """
        kept, self.why = self.view, ""
        if kept is not None and kept.info.revision == revision:
            return kept
        view = self._ask(revision)
        if kept is not None and kept.info.revision > revision:
            if view is not None and view.info.revision < kept.info.revision:
                logger.info("world/info: revision %d after %d: a new world", view.info.revision, kept.info.revision)
                self.view = view
                return self._at(view, revision)
            self.why = ""  # the kept view serves (a late message)
            return kept
        if view is not None:
            self.view = view
            return self._at(view, revision)
        return None

    def _at(self, view: WorldView, revision: int) -> WorldView | None:
        if view.info.revision >= revision:
            self.why = ""
            return view
        self.why = f"the world answered revision {view.info.revision}, older than {revision}"
        return None

    def _ask(self, revision: int) -> WorldView | None:
        """The world's answer to ``world/info`` (of several, the one at ``revision``, else the
        newest), or None; :attr:`why` says what came when none serves."""
        answers = self.bus.query(keys.info(self.sim), timeout_s=self.timeout_s)
        views = [v for v in (self._build(data, "answer") for data in answers) if v is not None]
        revisions = tuple(v.info.revision for v in views)
        if len(views) > 1 and revisions != self._answered:  # logged once per set of answers
            logger.warning(
                "world/info: %d answers (revisions %s): is another world running on simulation %r?",
                len(views),
                list(revisions),
                self.sim,
            )
        self._answered = revisions if len(views) > 1 else ()
        if not views:
            self.why = (
                f"{len(answers)} answers to {keys.info(self.sim)}, none usable (refused above)"
                if answers
                else f"no answer to {keys.info(self.sim)} within {self.timeout_s:g} s (no world reached)"
            )
            return None
        return next((v for v in views if v.info.revision == revision), max(views, key=lambda v: v.info.revision))

    def take(self, data: bytes) -> WorldView | None:
        """Takes the world's description as it published it (at every revision): the new view,
        ready before a message of that revision asks for it; None when it is not newer (or
        refused).

        Args:
            data: A published ``WorldInfo``.
        """
        view = self._build(data, "publication")
        if view is None or (self.view is not None and view.info.revision <= self.view.info.revision):
            return None
        self.view = view
        return view

    def _build(self, data: bytes, what: str) -> WorldView | None:
        """A view from an encoded ``WorldInfo`` (the scene kept while the lab is the same)."""
        try:
            info = decode(data, WorldInfo)
            lab = lab_from_msg(info.lab)
            key = (info.lab.name, len(lab.walls), tuple(w.corners for w in lab.walls))
            specs = {s.id: spec_from_msg(s) for s in info.robots}
            if self._scene is None or key != self._scene_key:
                self._scene = Scene(lab)
                self._scene_key = key
        except (IwError, ValueError) as e:  # not the world's: a robot or a wall it cannot have
            logger.warning("world/info %s refused: %s", what, e)
            return None
        return WorldView(info, self._scene, specs)
