"""The collision check's logic: a verdict on each tick's proposed poses (robot-robot and
robot-wall, on the next pose, exact polygons; or the Ciber-Rato rule in the legacy profile)."""

from __future__ import annotations

import numpy as np

from iw_zenoh.core.collision import check_collisions, check_collisions_ciberrato
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.spec import RobotType
from iw_zenoh.messages import Hit, Proposed, Verdict
from iw_zenoh.sim.view import WorldView

__all__ = ["CollisionNode"]


class CollisionNode:
    """Turns a proposal into a verdict (logic only)."""

    def on_proposed(self, msg: Proposed, view: WorldView) -> Verdict:
        """The verdict on one proposal."""
        ids = msg.ids
        now = np.column_stack([msg.x, msg.y, msg.heading]) if ids else np.zeros((0, 3))
        nxt = np.column_stack([msg.next_x, msg.next_y, msg.next_heading]) if ids else np.zeros((0, 3))
        active = np.asarray(msg.active, dtype=bool)
        bodies = view.bodies_for(ids)
        if view.info.profile == Profile.CIBERRATO:
            col = check_collisions_ciberrato(view.scene, now, nxt, np.asarray(msg.linear), active=active)
            hits = [Hit(robot_id=ids[i], other=ids[j]) for i, j in col.robot_pairs]
        else:
            doors = np.asarray([t == RobotType.DOOR for t in bodies.types], dtype=bool)
            col = check_collisions(view.scene, bodies.outline, now, nxt, active=active, ignore_walls=doors)
            hits = [Hit(robot_id=ids[i], other=ids[j]) for i, j in col.robot_pairs]
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
