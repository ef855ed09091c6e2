"""``iwz sensors [--shard K/N]``: every robot's readings each tick (the logic, shards and noise:
:mod:`iw_zenoh.sim.sensors`).

Each reading goes out twice from one encoding: on its robot's key, and in the shard's batch
(``world/sensors/K-N``) that agent hosts and bridges with many robots read instead.

Tick n's readings are computed ahead from the world's proposal while the collision process checks
it, and go out as soon as the collision verdict confirms the proposal (no robot collided:
:mod:`iw_zenoh.sim.early`), without waiting for the world's state: the state only checks them,
and in the rare tick the world held after all (a verdict after its deadline) the readings that
differ go out again, corrected. Otherwise (a robot collided, nothing computed ahead, the
ciberrato profile) they go out when the state comes.
"""

from __future__ import annotations

import argparse
import logging
import time
from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.bus import Bus, Delivery, Inbox
from iw_zenoh.core import cones, laser, placing, read_all, readout
from iw_zenoh.core.modes import Profile
from iw_zenoh.errors import ProtocolError
from iw_zenoh.messages import Proposed, WorldState, encode_sensor_batch
from iw_zenoh.nodes.info import InfoCache
from iw_zenoh.nodes.role_options import SensorsOptions, add_sensors_arguments, parse_shard
from iw_zenoh.process.runtime import NodeIO, options_from_args, start_role
from iw_zenoh.sim.early import Verdicts
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
    early: bool = True,
) -> None:
    """Computes readings for every committed state until stopped, ahead on proposals (unless
    ``ahead`` is false), published as soon as the collision verdict confirms the proposal (unless
    ``early`` is false: then when the state comes)."""
    io = io or NodeIO(bus, sim, "sensors", name)
    loop = _Loop(io, sim, shard, ahead=ahead, early=early and ahead)
    io.alive()
    while not io.stop.is_set():
        loop.once()


class _Loop:
    """The sensors' inboxes and what one pass of the loop keeps between passes."""

    def __init__(self, io: NodeIO, sim: str, shard: tuple[int, int], *, ahead: bool, early: bool) -> None:
        self.io, self.sim, self.shard = io, sim, shard
        self.states = io.inbox(keys.state(sim))
        self.proposals = io.inbox(keys.proposed(sim)) if ahead else Inbox()
        self.verdicts = io.inbox(keys.verdict(sim)) if early else Inbox()
        self.infos = io.inbox(keys.info(sim))  # published at every revision: the view is ready before it is asked for
        self.cache = InfoCache(io.bus, sim)
        self.window = ViewWindow(self.cache.get)
        self.node: SensorsNode | None = None
        self.ahead: Computed | None = None  # the next tick's readings, computed from its proposal
        self.legacy = False  # ... in the ciberrato profile
        self.proposal: tuple[Proposed, WorldView] | None = None  # the newest proposal not computed yet, its view
        self.said = Verdicts()  # the verdicts of the next ticks
        self.ahead_from = 0  # compute ahead from this tick on

    def once(self) -> None:
        """One pass: the states waiting, else a proposal to compute ahead or a verdict to act on, else a wait."""
        fresh = [self.cache.take(data) for _, data, _ in self.infos.drain()[-1:]]
        self._take_verdicts()
        pending = self.states.drain()
        if pending:
            self._on_states(pending)
            return
        node = self.node
        props = self.proposals.drain()
        if props and node is not None and node.last_tick + 1 >= self.ahead_from:
            for d in props:  # each checked, so a bad one is reported even when a newer one follows
                p = self.io.decode(d, Proposed)
                view = _checked(self.io, self.window, d[0], p, self.cache) if p is not None else None
                if p is not None and view is not None:
                    self.proposal = (p, view)
        if self.proposal is not None and node is not None and node.early is None:
            (p, view), self.proposal = self.proposal, None
            self.ahead, self.legacy = node.ahead(p, view), view.info.profile == Profile.CIBERRATO
            self._send_early()
            return
        if self._send_early():
            return
        _warm(fresh, node, self.sim, self.shard)  # idle: the new roster computed once
        self.io.wait(0.2)

    def _take_verdicts(self) -> None:
        """Keeps the verdicts of the next ticks; each refused is reported (:meth:`_report_verdicts`)."""
        now, ticks = time.monotonic_ns(), self.window.ticks
        self.said.take((data for _, data, _ in self.verdicts.drain()), lambda tick: ticks.ahead(tick, now))
        self._report_verdicts()

    def _report_verdicts(self) -> None:
        """Reports each verdict refused as a bad message with its reason."""
        for why in self.said.refusals():
            self.io.bad_message(keys.verdict(self.sim), ProtocolError(why))

    def _send_early(self) -> bool:
        """Publishes the readings computed ahead if the verdict on their proposal confirms it
        (:func:`iw_zenoh.sim.early.confirms`); in the ciberrato profile never (the legacy bridge
        pairs a tick's readings with the score and the end of the run that tick's state brings)."""
        a, node = self.ahead, self.node
        if a is None or node is None or node.early is not None or a.msg.tick != node.last_tick + 1:
            return False
        if self.legacy or not self.said.confirm(a.msg):
            return False
        node.send_early(a)
        self.ahead = None
        _publish(self.io.bus, self.sim, self.shard, a)
        logger.debug("tick %d: the verdict confirmed the proposal, readings published before the state", a.msg.tick)
        return True

    def _on_states(self, pending: list[Delivery]) -> None:
        """Settles the states waiting: one tick of backlog (a slow tick: a new robot's bodies, a
        busy machine) is caught up, so legacy clients and recordings get every tick; after a
        longer stall only the newest are worth computing. Every message is decoded so a bad one
        is always reported."""
        io = self.io
        decoded = [m for m in (io.decode(d, WorldState) for d in pending) if m is not None]
        for msg in decoded[-CATCH_UP:]:
            view = _checked(io, self.window, keys.state(self.sim), msg, self.cache)
            if view is None:
                continue
            self.said.settle(msg)
            self._report_verdicts()
            if self.node is None:
                self.node = SensorsNode(self.sim, view.info.seed, self.shard)
            node = self.node
            if node.early is not None and node.early.msg.tick == msg.tick:
                self._check_early(node, msg, view)
                continue
            node.forget_early()  # a newer state than the tick that went out early: that one stands
            debug = logger.isEnabledFor(logging.DEBUG)  # its figures are not worked out otherwise
            t0, c0 = (time.perf_counter(), time.process_time()) if debug else (0.0, 0.0)
            used = self.ahead if self.ahead is not None and self.ahead.msg.tick == msg.tick else None
            c, again = node.settle(used, msg, view)
            self.ahead = None
            if used is not None and again > MISSED_AHEAD * max(1, len(c.out)):
                self.ahead_from = msg.tick + 1 + PAUSE_AHEAD
            t1, c1 = (time.perf_counter(), time.process_time()) if debug else (0.0, 0.0)
            _publish(io.bus, self.sim, self.shard, c)
            if debug and msg.tick_wall_ns:
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

    def _check_early(self, node: SensorsNode, msg: WorldState, view: WorldView) -> None:
        """The state of a tick whose readings went out early: nothing more when it is what they
        were computed from; otherwise the readings that differ go out again, corrected."""
        before = node.corrections
        c = node.check_early(msg, view)
        if node.corrections == before:
            return
        self.ahead = None  # computed from the early tick's encoder counts, perhaps wrong
        logger.warning(
            "tick %d: readings went out when the verdict confirmed the proposal, but the world committed "
            "another state (%s): %d readings published again, corrected (%d such ticks so far)",
            msg.tick,
            f"held: {msg.held_reason}" if msg.held else "not the proposal",
            0 if c is None else len(c.out),
            node.corrections,
        )
        if c is not None:
            _publish(self.io.bus, self.sim, self.shard, c)


def _warm(fresh: list[WorldView | None], node: SensorsNode | None, sim: str, shard: tuple[int, int]) -> None:
    """Computes a new roster once, taken from the world's description as it is published, so its
    first state does not wait on what its first readings build (a state waiting computes it anyway)."""
    for view in fresh:
        if view is not None:
            (node or SensorsNode(sim, view.info.seed, shard)).warm(view)


def _checked(
    io: NodeIO, window: ViewWindow[WorldView], key: str, msg: WorldState | Proposed, cache: InfoCache
) -> WorldView | None:
    """The view to compute ``msg`` in, or None; a refused one (a tick too far ahead, robots the
    world does not have) is reported as a bad message."""
    view, why = window.view(msg, time.monotonic_ns())
    if why:
        io.bad_message(key, ProtocolError(why))
    elif view is None:
        logger.warning(
            "tick %d: no world info for revision %d and robots %s (%s)",
            msg.tick,
            msg.revision,
            msg.ids[:5],
            cache.why or "a newer revision without its robots",
        )
    return view


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
            "  iwz sensors --options '{\"shard\": [2, 2]}'    (as iwz run starts it)\n"
            "Readings go out once the collision verdict confirms a tick; to compare,\n"
            "only once the world's state comes:\n"
            "  iwz sensors --no-early"
        ),
        arguments=add_sensors_arguments,
        warm_up=_warm_up,  # before joining: the first tick must not wait for a compilation
        prepare=_options,
        run=lambda proc, o: run(proc.bus, proc.sim, shard=o.shard, io=proc.io, ahead=o.ahead, early=o.early),
        name=lambda args: _options(args).process_name,
        name_help="sensors-K-N",
    )


def _options(args: argparse.Namespace) -> SensorsOptions:
    return options_from_args(args, SensorsOptions)


def _warm_up() -> None:
    """Compiles (or loads from the cache) the cones' and the laser scanners' kernels."""
    cones.warm_up()
    laser.warm_up()
    placing.warm_up()  # the wedges, mounting points and outlines they are given
    readout.warm_up()  # the noise on what they read
    read_all.warm_up()  # all of them in one call, the usual tick's path
