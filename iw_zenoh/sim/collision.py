"""The collision check's logic: a verdict on each tick's proposed poses (robot-robot and
robot-wall, on the next pose, exact polygons; or the Ciber-Rato rule in the legacy profile)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.collision import Collisions, check_collisions, check_collisions_ciberrato
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.spec import RobotType
from iw_zenoh.messages import Hit, Proposed, Verdict
from iw_zenoh.sim.view import WorldView

__all__ = ["CollisionNode"]


class CollisionNode:
    """Turns a proposal into a verdict (logic only)."""

    def __init__(self) -> None:
        self._doors: tuple[Bodies, npt.NDArray[np.bool_]] | None = None  # per roster, not per tick

    def doors_of(self, bodies: Bodies) -> npt.NDArray[np.bool_]:
        """(N,) which of these bodies are doors: they pass through walls and each other
        (computed again only when the roster's bodies change)."""
        if self._doors is None or self._doors[0] is not bodies:
            self._doors = (bodies, np.asarray([t == RobotType.DOOR for t in bodies.types], dtype=bool))
        return self._doors[1]

    def warm(self, view: WorldView) -> None:
        """Checks the view's robots once, where they were placed, and forgets the verdict, so
        that what a check builds on first use (the lab's segments and their R-tree, the robots'
        bodies: several milliseconds) is built before the revision's first proposal waits on it:
        a verdict later than the world waits makes it hold every robot still, which changes a run."""
        robots = [r for r in view.info.robots if r.id in view.specs]
        if not robots:
            return
        n = len(robots)
        ids = [r.id for r in robots]
        x = [view.info.lab.width / 2 if r.x_m is None else r.x_m for r in robots]
        y = [view.info.lab.height / 2 if r.y_m is None else r.y_m for r in robots]
        heading = [0.0] * n
        probe = Proposed(
            revision=view.info.revision,
            ids=ids,
            x=x,
            y=y,
            heading=heading,
            next_x=x,
            next_y=y,
            next_heading=heading,
            linear=[0.0] * n,
            active=[True] * n,
        )
        self.on_proposed(probe, view)

    def check(
        self,
        view: WorldView,
        bodies: Bodies,
        now: np.ndarray,
        nxt: np.ndarray,
        linear: np.ndarray,
        active: npt.NDArray[np.bool_] | None = None,
    ) -> Collisions:
        """The collisions of one proposal, as arrays: (N, 3) poses now and next, (N,) linear
        motion (the legacy rule's sign), in the order of ``bodies`` (what :meth:`on_proposed`
        judges, without messages: :class:`~iw_zenoh.sim.local.LocalWorld`'s array path)."""
        if view.info.profile == Profile.CIBERRATO:
            return check_collisions_ciberrato(view.scene, now, nxt, linear, active=active)
        # doors pass through walls and each other: the leaves of one revolving door cross at its hub
        # (each leaf is a Door robot turning about the hub), and two leaves of a double door meet
        doors = self.doors_of(bodies)
        return check_collisions(
            view.scene, bodies.outline, now, nxt, active=active, ignore_walls=doors, pass_each_other=True
        )

    def on_proposed(self, msg: Proposed, view: WorldView) -> Verdict:
        """The verdict on one proposal."""
        ids = msg.ids
        now = np.column_stack([msg.x, msg.y, msg.heading]) if ids else np.zeros((0, 3))
        nxt = np.column_stack([msg.next_x, msg.next_y, msg.next_heading]) if ids else np.zeros((0, 3))
        active = np.asarray(msg.active, dtype=bool)
        col = self.check(view, view.bodies_for(ids), now, nxt, np.asarray(msg.linear), active)
        hits = [Hit(robot_id=ids[i], other=ids[j]) for i, j in col.robot_pairs]
        if view.info.profile != Profile.CIBERRATO:  # pairs are i < j once: each robot hit the other
            hits += [Hit(robot_id=ids[j], other=ids[i]) for i, j in col.robot_pairs]
        hits += [Hit(robot_id=ids[i], wall=int(w)) for i, w in col.wall_pairs]
        return Verdict(
            tick=msg.tick,
            sim_time_ns=msg.sim_time_ns,
            revision=msg.revision,
            ids=list(ids),
            collided=col.collided.tolist(),
            hits=hits,
        )
