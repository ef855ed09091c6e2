"""``iwz collision``: verdicts on each tick's proposed poses (the logic:
:mod:`iw_zenoh.sim.collision`)."""

from __future__ import annotations

import argparse
import logging
import time
from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.bus import Bus, ZenohBus
from iw_zenoh.cliargs import add_common_arguments, net_from_args
from iw_zenoh.core.contact import warm_up
from iw_zenoh.errors import IwError
from iw_zenoh.messages import Proposed
from iw_zenoh.nodes.base import NodeIO, install_stop_signals, setup_logging
from iw_zenoh.nodes.info import InfoCache
from iw_zenoh.sim.collision import CollisionNode

__all__ = ["main", "run"]

logger = logging.getLogger(__name__)


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
    p = argparse.ArgumentParser(prog="iwz collision", description="Collision verdicts on every tick's proposed poses.")
    p.add_argument("--name", default="collision", help="instance name (liveliness)")
    add_common_arguments(p)
    args = p.parse_args(argv)
    setup_logging(args.verbose, "collision")
    t0 = time.monotonic()
    warm_up()  # before joining: the first verdict must not wait for a compilation
    if time.monotonic() - t0 > 1.0:
        logger.info("contact kernel compiled in %.1f s (cached for later runs)", time.monotonic() - t0)
    try:
        bus = ZenohBus(net_from_args(args))
    except (IwError, ValueError) as e:
        print(f"iwz collision: {e}")
        return 2
    io = NodeIO(bus, keys.chunk(args.sim), "collision", args.name)
    install_stop_signals(io.stop, io.wake.set)
    try:
        run(bus, args.sim, io=io)
    finally:
        bus.close()
    return 0
