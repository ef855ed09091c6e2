"""``iwz collision``: verdicts on each tick's proposed poses (the logic:
:mod:`iw_zenoh.sim.collision`)."""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.bus import Bus
from iw_zenoh.core.collide import warm_up
from iw_zenoh.errors import ProtocolError
from iw_zenoh.messages import Proposed
from iw_zenoh.nodes.info import InfoCache
from iw_zenoh.process.runtime import NodeIO, start_role
from iw_zenoh.sim.collision import CollisionNode
from iw_zenoh.sim.view import WorldView
from iw_zenoh.ticks import ViewWindow

__all__ = ["main", "run"]

logger = logging.getLogger(__name__)


def _newest(
    io: NodeIO, window: ViewWindow[WorldView], key: str, decoded: list[Proposed]
) -> tuple[Proposed, WorldView | None] | None:
    """The newest proposal that is not refused (a forged one, too far ahead or naming robots the
    world does not have, is reported as a bad message), and its view of the world (None: no
    world info for it); None when every one is refused."""
    for msg in reversed(decoded):
        view, why = window.view(msg, time.monotonic_ns())
        if not why:
            return msg, view
        io.bad_message(key, ProtocolError(why))
    return None


def run(bus: Bus, sim: str, *, name: str = "collision", io: NodeIO | None = None) -> None:
    """Answers every proposal with a verdict until stopped."""
    io = io or NodeIO(bus, sim, "collision", name)
    inbox = io.inbox(keys.proposed(sim))
    infos = io.inbox(keys.info(sim))  # published at every revision: the view is ready before it is asked for
    cache = InfoCache(bus, sim)
    window = ViewWindow(cache.get)
    node = CollisionNode()
    io.alive()
    while not io.stop.is_set():
        fresh = [cache.take(data) for _, data, _ in infos.drain()[-1:]]
        pending = inbox.drain()
        if not pending:
            for view in fresh:  # idle: the new roster checked once (a proposal waiting checks it anyway)
                if view is not None:
                    node.warm(view)
            io.wait(0.2)
            continue
        # only the newest proposal matters (an older one's tick is already decided), but every
        # message is decoded so a bad one is always reported
        decoded = [m for m in (io.decode(d, Proposed) for d in pending) if m is not None]
        if not decoded:
            continue
        newest = _newest(io, window, keys.proposed(sim), decoded)
        if newest is None:
            continue
        msg, view = newest
        if view is None:
            logger.warning(
                "tick %d: no world info for revision %d (%s); no verdict (the world holds robots)",
                msg.tick,
                msg.revision,
                cache.why or "a newer revision without its robots",
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
