"""``iwz sensors [--shard K/N]``: every robot's readings each tick (the logic, shards and noise:
:mod:`iw_zenoh.sim.sensors`).

Each reading goes out twice from one encoding: on its robot's key, and in the shard's batch
(``world/sensors/K-N``) that agent hosts and bridges with many robots read instead.
"""

from __future__ import annotations

import argparse
import logging
import time
from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.bus import Bus, Delivery, Inbox
from iw_zenoh.core import cones, laser
from iw_zenoh.errors import ProtocolError
from iw_zenoh.messages import Proposed, WorldState, encode_sensor_batch
from iw_zenoh.nodes.info import InfoCache
from iw_zenoh.nodes.role_options import SensorsOptions, add_sensors_arguments, parse_shard
from iw_zenoh.runtime import NodeIO, options_from_args, start_role
from iw_zenoh.sim.sensors import Computed, SensorsNode
from iw_zenoh.sim.view import WorldView
from iw_zenoh.ticks import ViewWindow

__all__ = ["main", "parse_shard", "run"]  # parse_shard: from role_options, where it now lives

logger = logging.getLogger(__name__)

CATCH_UP = 2  # states computed at once after a stall: the newest and the one before
MISSED_AHEAD = 0.25  # a tick whose readings were this much computed again ...
PAUSE_AHEAD = 20  # ... stops computing ahead for this many ticks (stuck robots collide every tick)


def run(
    bus: Bus,
    sim: str,
    *,
    shard: tuple[int, int] = (1, 1),
    name: str = "sensors",
    io: NodeIO | None = None,
    ahead: bool = True,
) -> None:
    """Computes readings for every committed state until stopped, ahead on proposals (unless ``ahead`` is false)."""
    io = io or NodeIO(bus, sim, "sensors", name)
    inbox = io.inbox(keys.state(sim))
    proposals = io.inbox(keys.proposed(sim)) if ahead else Inbox()
    infos = io.inbox(keys.info(sim))  # published at every revision: the view is ready before it is asked for
    cache = InfoCache(bus, sim)
    window = ViewWindow(cache.get)
    node: SensorsNode | None = None
    early: Computed | None = None
    ahead_from = 0  # compute ahead from this tick on
    io.alive()
    while not io.stop.is_set():
        fresh = [cache.take(data) for _, data, _ in infos.drain()[-1:]]
        pending = inbox.drain()
        if not pending:
            props = proposals.drain()
            if props and node is not None and node.last_tick + 1 >= ahead_from:
                early = _ahead(io, window, node, props[-1], early)
                continue
            _warm(fresh, node, sim, shard)  # idle: the new roster computed once
            io.wait(0.2)
            continue
        # one tick of backlog (a slow tick: a new robot's bodies, a busy machine) is caught up,
        # so legacy clients and recordings get every tick; after a longer stall only the newest
        # are worth computing. Every message is decoded so a bad one is always reported.
        decoded = [m for m in (io.decode(d, WorldState) for d in pending) if m is not None]
        for msg in decoded[-CATCH_UP:]:
            view = _checked(io, window, keys.state(sim), msg)
            if view is None:
                continue
            if node is None:
                node = SensorsNode(sim, view.info.seed, shard)
            t0, c0 = time.perf_counter(), time.process_time()
            used = early if early is not None and early.msg.tick == msg.tick else None
            c, again = node.settle(used, msg, view)
            early = None
            if used is not None and again > MISSED_AHEAD * max(1, len(c.out)):
                ahead_from = msg.tick + 1 + PAUSE_AHEAD
            t1, c1 = time.perf_counter(), time.process_time()
            _publish(bus, sim, shard, c)
            if msg.tick_wall_ns:
                logger.debug(
                    "tick %d: state arrived %.2f ms after the tick began, %s, settled in %.2f ms (CPU %.2f ms), "
                    "published in %.2f ms",
                    msg.tick,
                    (pending[-1][2] - msg.tick_wall_ns) / 1e6,
                    "not computed ahead" if used is None else f"computed ahead, {again} robots again",
                    (t1 - t0) * 1e3,
                    (c1 - c0) * 1e3,
                    (time.perf_counter() - t1) * 1e3,
                )


def _warm(fresh: list[WorldView | None], node: SensorsNode | None, sim: str, shard: tuple[int, int]) -> None:
    """Computes a new roster once, taken from the world's description as it is published, so its
    first state does not wait on what its first readings build (a state waiting computes it anyway)."""
    for view in fresh:
        if view is not None:
            (node or SensorsNode(sim, view.info.seed, shard)).warm(view)


def _checked(io: NodeIO, window: ViewWindow[WorldView], key: str, msg: WorldState | Proposed) -> WorldView | None:
    """The view to compute ``msg`` in, or None; a refused one (a tick too far ahead, robots the
    world does not have) is reported as a bad message."""
    view, why = window.view(msg, time.monotonic_ns())
    if why:
        io.bad_message(key, ProtocolError(why))
    elif view is None:
        logger.warning("tick %d: no world info for revision %d and robots %s", msg.tick, msg.revision, msg.ids[:5])
    return view


def _ahead(
    io: NodeIO, window: ViewWindow[WorldView], node: SensorsNode, d: Delivery, early: Computed | None
) -> Computed | None:
    """Tick n's readings computed ahead from its proposal while the collision process checks it
    (``early`` when the proposal cannot be used: malformed, refused, or no world info for it)."""
    p = io.decode(d, Proposed)
    view = _checked(io, window, d[0], p) if p is not None else None
    if p is not None and view is not None:
        return node.ahead(p, view)
    return early


def _publish(bus: Bus, sim: str, shard: tuple[int, int], c: Computed) -> None:
    """Publishes one tick's readings: each on its robot's key, then all in the shard's batch."""
    for (key, _), data in zip(c.out, c.encoded, strict=True):
        bus.publish(key, data)
    msg = c.msg
    bus.publish(
        keys.sensor_batch(sim, shard),
        encode_sensor_batch(
            msg.tick,
            msg.sim_time_ns,
            f"{shard[0]}-{shard[1]}",
            c.encoded,
            msg.tick_wall_ns,
            [m.robot_id for _, m in c.out],
        ),
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz sensors``."""
    return start_role(
        argv,
        role="sensors",
        description=(
            "Computes every robot's sensors each tick (proximity cones, compass, beacons, GPS, "
            "ground, collision, encoders, bumpers, laser scanners)."
        ),
        epilog=(
            "Split the robots between processes or hosts, one shard on each:\n"
            "  iwz sensors --shard 1/2\n"
            "  iwz sensors --shard 2/2 --connect tcp/HOST:7447\n"
            "  iwz sensors --options '{\"shard\": [2, 2]}'    (as iwz run starts it)"
        ),
        arguments=add_sensors_arguments,
        warm_up=_warm_up,  # before joining: the first tick must not wait for a compilation
        prepare=_options,
        run=lambda proc, o: run(proc.bus, proc.sim, shard=o.shard, io=proc.io, ahead=o.ahead),
        name=lambda args: _options(args).process_name,
        name_help="sensors-K-N",
    )


def _options(args: argparse.Namespace) -> SensorsOptions:
    return options_from_args(args, SensorsOptions)


def _warm_up() -> None:
    """Compiles (or loads from the cache) the cones' and the laser scanners' kernels."""
    cones.warm_up()
    laser.warm_up()
