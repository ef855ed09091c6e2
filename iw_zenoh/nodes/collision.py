"""``iwz collision``: verdicts on each tick's proposed poses (robot-robot and robot-wall, on the
next pose, exact polygons; or the Ciber-Rato rule in the legacy profile)."""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence

import numpy as np

from iw_zenoh import keys
from iw_zenoh.bus import Bus
from iw_zenoh.core.collision import check_collisions, check_collisions_ciberrato
from iw_zenoh.core.contact import warm_up
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.spec import RobotType
from iw_zenoh.messages import Hit, Proposed, Verdict
from iw_zenoh.nodes.info import InfoCache, WorldView
from iw_zenoh.runtime import NodeIO, start_role

__all__ = ["CollisionNode", "main", "run"]

logger = logging.getLogger(__name__)


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


def run(bus: Bus, sim: str, *, name: str = "collision", io: NodeIO | None = None) -> None:
    """Answers every proposal with a verdict until stopped."""
    io = io or NodeIO(bus, sim, "collision", name)
    inbox = io.inbox(keys.proposed(sim))
    cache = InfoCache(bus, sim)
    node = CollisionNode()
    io.alive()
    while not io.stop.is_set():
        pending = inbox.drain()
        if not pending:
            io.wait(0.2)
            continue
        # only the newest proposal matters (an older one's tick is already decided), but every
        # message is decoded so a bad one is always reported
        decoded = [m for m in (io.decode(d, Proposed) for d in pending) if m is not None]
        if not decoded:
            continue
        msg = decoded[-1]
        view = cache.get(msg.revision)
        if view is None or any(i not in view.specs for i in msg.ids):
            logger.warning(
                "tick %d: no world info for revision %d; no verdict (the world holds robots)", msg.tick, msg.revision
            )
            continue
        verdict = node.on_proposed(msg, view)
        io.send(keys.verdict(sim), verdict)
        if logger.isEnabledFor(logging.DEBUG):
            logger.debug(
                "tick %d: proposal arrived %.2f ms after the tick began, verdict sent %.2f ms after it arrived",
                msg.tick,
                (pending[-1][2] - msg.tick_wall_ns) / 1e6 if msg.tick_wall_ns else float("nan"),
                (time.time_ns() - pending[-1][2]) / 1e6,
            )


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz collision``."""
    return start_role(
        argv,
        role="collision",
        description="Collision verdicts on every tick's proposed poses (robot-robot and robot-wall, on the next pose).",
        epilog="Example (beside a world; iwz run starts it for you):\n  iwz collision -v",
        warm_up=warm_up,  # before joining: the first verdict must not wait for a compilation
        run=lambda proc: run(proc.bus, proc.sim, io=proc.io),
    )
