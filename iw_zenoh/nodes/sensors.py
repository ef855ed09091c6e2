"""``iwz sensors [--shard K/N]``: every robot's readings each tick.

Each reading goes out twice from one encoding: on its robot's key, and in the shard's batch
(``world/sensors/K-N``) that agent hosts and bridges with many robots read instead.

With ``--shard K/N`` this process computes the robots whose id is K modulo N (K from 1), so
several sensor processes, on several hosts, split the robots; every robot is still an obstacle
to every sensor. Noise comes from each robot's own seeded stream, so a robot's readings are the
same whichever shard computes them.
"""

from __future__ import annotations

import argparse
import logging
import time
from collections.abc import Sequence

import numpy as np

from iw_zenoh import keys
from iw_zenoh.bus import Bus, ZenohBus
from iw_zenoh.cliargs import add_common_arguments, net_from_args
from iw_zenoh.core.cones import warm_up
from iw_zenoh.core.noise import NoiseStreams, Stream
from iw_zenoh.core.sensors import SensorParams, noise_layout, read_sensors
from iw_zenoh.errors import IwError
from iw_zenoh.messages import SensorReading, WorldState, encode, encode_sensor_batch
from iw_zenoh.nodes.base import NodeIO, Outgoing, install_stop_signals, setup_logging
from iw_zenoh.nodes.info import InfoCache, WorldView

__all__ = ["SensorsNode", "main", "parse_shard", "run"]

logger = logging.getLogger(__name__)

CATCH_UP = 2  # states computed at once after a stall: the newest and the one before


def parse_shard(text: str) -> tuple[int, int]:
    """Parses ``K/N`` (1 <= K <= N).

    Raises:
        ValueError: Saying what a shard looks like.
    """
    k, sep, n = text.partition("/")
    try:
        kk, nn = int(k), int(n)
    except ValueError:
        kk = nn = 0
    if not sep or nn < 1 or not 1 <= kk <= nn:
        raise ValueError(f"--shard takes K/N with 1 <= K <= N (e.g. 2/3), got {text!r}")
    return kk, nn


class SensorsNode:
    """Computes the readings of one shard's robots from a committed state (logic only).

    Args:
        sim: Simulation name.
        seed: The run's seed (each robot's sensor stream derives from it).
        shard: ``(K, N)``.
    """

    def __init__(self, sim: str, seed: int = 0, shard: tuple[int, int] = (1, 1)) -> None:
        self.sim = sim
        self.seed = seed
        self.shard = shard
        self._noise = NoiseStreams(seed, Stream.SENSORS)
        self._enc_ids: list[int] = []  # the roster of the last tick, and its encoder counts
        self._enc = np.zeros((0, 2))
        self._keys: dict[int, str] = {}  # robot id -> its sensors key (built once)

    def mine(self, robot_id: int) -> bool:
        """Whether this shard computes ``robot_id``."""
        k, n = self.shard
        return robot_id % n == k % n

    def on_state(self, msg: WorldState, view: WorldView) -> list[Outgoing]:
        """Every reading of this shard's robots for tick n."""
        ids = list(msg.ids)
        if not ids:
            return []
        bodies = view.bodies_for(ids)
        pose = np.column_stack([msg.x, msg.y, msg.heading])
        k, n = self.shard
        only = np.asarray(ids, dtype=np.int64) % n == k % n
        # robots that carry a beacon (Ciber-Rato's RobotBeacon), in id order after the lab's
        moving = tuple((i, h) for i, rid in enumerate(ids) if (h := view.specs[rid].beacon_height_m) is not None)
        nb = len(view.scene.lab.beacons) + len(moving)
        counts, starts = noise_layout(bodies, nb)
        z = np.zeros(int(counts.sum()))
        take = self._noise.take
        for i, rid, s0, c in zip(range(len(ids)), ids, starts.tolist(), counts.tolist(), strict=True):
            if only[i]:
                z[s0 : s0 + c] = take(rid, c)
        if ids == self._enc_ids:
            enc = self._enc
        else:  # the roster changed: carry each remaining robot's count over
            before = {rid: row for rid, row in zip(self._enc_ids, self._enc.tolist(), strict=True)}
            enc = np.asarray([before.get(rid, (0.0, 0.0)) for rid in ids], dtype=np.float64).reshape(-1, 2)
        params = SensorParams()
        r = read_sensors(
            view.scene,
            bodies,
            pose,
            collided=np.asarray(msg.collided, dtype=bool),
            encoder_acc=enc,
            rolled_m=np.column_stack([msg.rolled_left, msg.rolled_right]),
            z=z,
            params=params,
            only=only,
            legacy_ir=view.info.profile == "ciberrato",
            moving_beacons=moving,
        )
        self._enc_ids, self._enc = ids, np.where(only[:, None], r.encoder_acc, enc)
        out: list[Outgoing] = []
        # whole arrays to Python lists once; each robot's sensors are a contiguous run
        m_first = np.searchsorted(bodies.ir_owner, np.arange(len(ids))).tolist()
        m_last = np.searchsorted(bodies.ir_owner, np.arange(len(ids)), side="right").tolist()
        b_first = np.searchsorted(bodies.bumper_owner, np.arange(len(ids))).tolist()
        b_last = np.searchsorted(bodies.bumper_owner, np.arange(len(ids)), side="right").tolist()
        prox = np.where(np.isfinite(r.proximity_m), r.proximity_m, np.nan).tolist()
        prox = [None if v != v else v for v in prox]  # NaN (nothing in range) -> null
        legacy = r.proximity_legacy.tolist()
        pids = bodies.ir_id.tolist()
        beacons = [[None if v != v else v for v in row] for row in r.beacon_deg.tolist()]
        gps = r.gps.tolist()
        compass = r.compass_deg.tolist()
        ground = r.ground.tolist()
        collision = r.collision.tolist()
        ticks = r.encoder_ticks.tolist()
        bumpers = r.bumpers.tolist()
        for i in np.flatnonzero(only).tolist():
            rid = ids[i]
            lo, hi = m_first[i], m_last[i]
            reading = SensorReading(
                tick=msg.tick,
                sim_time_ns=msg.sim_time_ns,
                robot_id=rid,
                proximity_ids=pids[lo:hi],
                proximity_m=prox[lo:hi],
                proximity_legacy=legacy[lo:hi],
                compass_deg=compass[i],
                beacons_deg=beacons[i],
                gps=(gps[i][0], gps[i][1], gps[i][2]),
                ground=ground[i],
                collision=collision[i],
                encoders=(ticks[i][0], ticks[i][1]),
                bumpers=bumpers[b_first[i] : b_last[i]],
                tick_wall_ns=msg.tick_wall_ns,
            )
            key = self._keys.get(rid)
            if key is None:
                key = self._keys[rid] = keys.sensors(self.sim, rid)
            out.append((key, reading))
        return out


def run(
    bus: Bus, sim: str, *, shard: tuple[int, int] = (1, 1), name: str = "sensors", io: NodeIO | None = None
) -> None:
    """Computes readings for every committed state until stopped."""
    io = io or NodeIO(bus, sim, "sensors", name)
    inbox = io.inbox(keys.state(sim))
    cache = InfoCache(bus, sim)
    node: SensorsNode | None = None
    io.alive()
    while not io.stop.is_set():
        pending = inbox.drain()
        if not pending:
            io.wait(0.2)
            continue
        # one tick of backlog (a slow tick: a new robot's bodies, a busy machine) is caught up,
        # so legacy clients and recordings get every tick; after a longer stall only the newest
        # are worth computing. Every message is decoded so a bad one is always reported.
        decoded = [m for m in (io.decode(d, WorldState) for d in pending) if m is not None]
        for msg in decoded[-CATCH_UP:]:
            view = cache.get(msg.revision)
            if view is None or any(i not in view.specs for i in msg.ids):
                logger.warning("tick %d: no world info for revision %d", msg.tick, msg.revision)
                continue
            if node is None:
                node = SensorsNode(sim, view.info.seed, shard)
            t0, c0 = time.perf_counter(), time.process_time()
            out = node.on_state(msg, view)
            t1, c1 = time.perf_counter(), time.process_time()
            # each reading is encoded once: on its robot's key (agents, recorders, viewers) and
            # inside the shard's batch (hosts and bridges with many robots read one message)
            encoded = [encode(m) for _, m in out]
            for (key, _), data in zip(out, encoded, strict=True):
                bus.publish(key, data)
            bus.publish(
                keys.sensor_batch(sim, shard),
                encode_sensor_batch(msg.tick, msg.sim_time_ns, f"{shard[0]}-{shard[1]}", encoded, msg.tick_wall_ns),
            )
            if msg.tick_wall_ns:
                logger.debug(
                    "tick %d: state arrived %.2f ms after the tick began, computed in %.2f ms (CPU %.2f ms), "
                    "published in %.2f ms",
                    msg.tick,
                    (pending[-1][2] - msg.tick_wall_ns) / 1e6,
                    (t1 - t0) * 1e3,
                    (c1 - c0) * 1e3,
                    (time.perf_counter() - t1) * 1e3,
                )


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz sensors``."""
    p = argparse.ArgumentParser(
        prog="iwz sensors",
        description=(
            "Computes every robot's sensors each tick (proximity cones, compass, beacons, GPS, "
            "ground, collision, encoders, bumpers)."
        ),
        epilog="Split the robots between processes or hosts: iwz sensors --shard 1/2 on one, --shard 2/2 on another.",
    )
    p.add_argument("--shard", default="1/1", help="K/N: compute the robots whose id is K modulo N (default 1/1, all)")
    p.add_argument("--name", default="", help="instance name (liveliness; default sensors-K-N)")
    add_common_arguments(p)
    args = p.parse_args(argv)
    setup_logging(args.verbose, "sensors")
    t0 = time.monotonic()
    warm_up()  # before joining: the first tick must not wait for a compilation
    if time.monotonic() - t0 > 1.0:
        logger.info("proximity kernel compiled in %.1f s (cached for later runs)", time.monotonic() - t0)
    try:
        shard = parse_shard(args.shard)
        bus = ZenohBus(net_from_args(args))
    except (IwError, ValueError) as e:
        print(f"iwz sensors: {e}")
        return 2
    name = args.name or f"sensors-{shard[0]}-{shard[1]}"
    io = NodeIO(bus, keys.chunk(args.sim), "sensors", name)
    install_stop_signals(io.stop, io.wake.set)
    try:
        run(bus, args.sim, shard=shard, io=io)
    finally:
        bus.close()
    return 0
