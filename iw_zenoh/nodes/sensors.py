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
from dataclasses import dataclass, replace

import numpy as np

from iw_zenoh import keys
from iw_zenoh.bus import Bus, Inbox
from iw_zenoh.core.cones import warm_up
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.noise import NoiseStreams, Stream
from iw_zenoh.core.sensors import SensorParams, noise_layout, read_sensors
from iw_zenoh.messages import Outgoing, Proposed, SensorReading, WorldState, encode, encode_sensor_batch
from iw_zenoh.nodes.info import InfoCache, WorldView
from iw_zenoh.runtime import NodeIO, start_role

__all__ = ["Computed", "SensorsNode", "main", "parse_shard", "run", "state_from_proposal"]

logger = logging.getLogger(__name__)

CATCH_UP = 2  # states computed at once after a stall: the newest and the one before
ALL_AGAIN = 0.25  # when this share of robots is touched, all are computed again (no merging)
MISSED_AHEAD = 0.25  # a tick whose readings were this much computed again ...
PAUSE_AHEAD = 20  # ... stops computing ahead for this many ticks (stuck robots collide every tick)


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


@dataclass
class Computed:
    """One tick's readings of a shard, encoded, with what they were computed from.

    Attributes:
        msg: The state they were computed from (or the proposal's state, when ahead).
        ids: The roster, in array order.
        out: ``(key, reading)`` of this shard's robots, in roster order.
        encoded: Each reading encoded, the same order.
        enc: (N,) encoder counts after this tick, roster order (other shards' robots kept as were).
    """

    msg: WorldState
    ids: list[int]
    out: list[tuple[str, SensorReading]]
    encoded: list[bytes]
    enc: np.ndarray


def state_from_proposal(p: Proposed) -> WorldState:
    """The state tick n will commit if no robot collides and none is held."""
    n = len(p.ids)
    return WorldState(
        tick=p.tick,
        sim_time_ns=p.sim_time_ns,
        revision=p.revision,
        ids=list(p.ids),
        x=list(p.next_x),
        y=list(p.next_y),
        heading=list(p.next_heading),
        collided=[False] * n,
        rolled_left=list(p.rolled_left),
        rolled_right=list(p.rolled_right),
        speed=[0.0] * n,  # not read by sensors
        tick_wall_ns=p.tick_wall_ns,
    )


class SensorsNode:
    """Computes the readings of one shard's robots from a committed state (logic only).

    It may also compute ahead from the world's proposal of tick n (:meth:`ahead`) while the
    collision process checks it; when the committed state then equals the proposal (nothing
    collided, nothing held) those readings are the state's, bit for bit, and go out at once
    (:meth:`settle`). Robots that collided, and robots whose sensors reach them, are computed
    again from the state. Noise is drawn once per tick however often a tick is computed.

    Args:
        sim: Simulation name.
        seed: The run's seed (each robot's sensor stream derives from it).
        shard: ``(K, N)``.
    """

    def __init__(self, sim: str, seed: int = 0, shard: tuple[int, int] = (1, 1)) -> None:
        self.sim = sim
        self.seed = seed
        self.shard = shard
        self.last_tick = -1  # the newest tick whose readings went out
        self._noise = NoiseStreams(seed, Stream.SENSORS)
        self._z: tuple[int, list[int], np.ndarray] | None = None  # (tick, roster, its normals)
        self._enc_ids: list[int] = []  # the roster of the last tick, and its encoder counts
        self._enc = np.zeros((0, 2))
        self._keys: dict[int, str] = {}  # robot id -> its sensors key (built once)

    def on_state(self, msg: WorldState, view: WorldView) -> list[Outgoing]:
        """Every reading of this shard's robots for tick n (computed and committed)."""
        c = self.compute(msg, view)
        self.commit(c)
        return list(c.out)

    def ahead(self, proposal: Proposed, view: WorldView) -> Computed | None:
        """Readings of tick n computed from its proposal (not committed), or None when the
        previous tick's readings are not out yet (encoder counts would be stale)."""
        if self.last_tick >= 0 and proposal.tick != self.last_tick + 1:
            return None
        return self.compute(state_from_proposal(proposal), view)

    def settle(self, ahead: Computed | None, msg: WorldState, view: WorldView) -> tuple[Computed, int]:
        """The readings of committed state ``msg`` (committed), reusing what was computed ahead
        where the state equals the proposal; also how many robots were computed again."""
        if ahead is None or not _same_frame(ahead.msg, msg):
            c = self.compute(msg, view)
            self.commit(c)
            return c, len(c.out)
        again = _touched(ahead.msg, msg, view)
        if not again.any():
            c = replace(ahead, msg=msg)
        elif (
            again.mean() > ALL_AGAIN
            or view.info.profile == Profile.CIBERRATO  # its IR model's rays have no range to bound
            or any(view.specs[i].beacon_height_m is not None for i in msg.ids)  # a beacon that moves
        ):
            c = self.compute(msg, view)
        else:
            c = _merge(ahead, self.compute(msg, view, subset=again), again)
        self.commit(c)
        return c, int(again.sum()) if len(c.out) else 0

    def commit(self, c: Computed) -> None:
        """Makes ``c`` the newest tick: its encoder counts are the next tick's start."""
        self._enc_ids, self._enc = c.ids, c.enc
        self.last_tick = c.msg.tick
        if self._z is not None and self._z[0] <= c.msg.tick:
            self._z = None

    def _normals(self, tick: int, ids: list[int], counts: list[int], starts: list[int], only: np.ndarray) -> np.ndarray:
        """This tick's standard normals, drawn once per tick (a tick computed again reuses them)."""
        if self._z is not None and self._z[0] == tick and self._z[1] == ids:
            return self._z[2]
        z = np.zeros(int(sum(counts)))
        take = self._noise.take
        for i, rid, s0, c in zip(range(len(ids)), ids, starts, counts, strict=True):
            if only[i]:
                z[s0 : s0 + c] = take(rid, c)
        self._z = (tick, ids, z)
        return z

    def compute(self, msg: WorldState, view: WorldView, subset: np.ndarray | None = None) -> Computed:
        """Readings of this shard's robots for ``msg`` (of ``subset`` only, if given), not committed."""
        ids = list(msg.ids)
        if not ids:
            return Computed(msg, ids, [], [], np.zeros((0, 2)))
        bodies = view.bodies_for(ids)
        pose = np.column_stack([msg.x, msg.y, msg.heading])
        k, n = self.shard
        mine = np.asarray(ids, dtype=np.int64) % n == k % n
        only = mine if subset is None else mine & subset
        # robots that carry a beacon (Ciber-Rato's RobotBeacon), in id order after the lab's
        moving = tuple((i, h) for i, rid in enumerate(ids) if (h := view.specs[rid].beacon_height_m) is not None)
        nb = len(view.scene.lab.beacons) + len(moving)
        counts, starts = noise_layout(bodies, nb)
        z = self._normals(msg.tick, ids, counts.tolist(), starts.tolist(), mine)
        if ids == self._enc_ids:
            enc = self._enc
        else:  # the roster changed: carry each remaining robot's count over
            before = {rid: row for rid, row in zip(self._enc_ids, self._enc.tolist(), strict=True)}
            enc = np.asarray([before.get(rid, (0.0, 0.0)) for rid in ids], dtype=np.float64).reshape(-1, 2)
        r = read_sensors(
            view.scene,
            bodies,
            pose,
            collided=np.asarray(msg.collided, dtype=bool),
            encoder_acc=enc,
            rolled_m=np.column_stack([msg.rolled_left, msg.rolled_right]),
            z=z,
            params=SensorParams(),
            only=only,
            legacy_ir=view.info.profile == Profile.CIBERRATO,
            moving_beacons=moving,
        )
        out: list[tuple[str, SensorReading]] = []
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
        # each reading is encoded once: on its robot's key and inside the shard's batch
        encoded = [encode(m) for _, m in out]
        return Computed(msg, ids, out, encoded, np.where(only[:, None], r.encoder_acc, enc))


def _same_frame(a: WorldState, b: WorldState) -> bool:
    """Whether two states of one tick share everything but poses, flags and distances rolled."""
    return (a.tick, a.sim_time_ns, a.revision, a.tick_wall_ns, a.ids) == (
        b.tick,
        b.sim_time_ns,
        b.revision,
        b.tick_wall_ns,
        b.ids,
    )


def _touched(ahead: WorldState, msg: WorldState, view: WorldView) -> np.ndarray:
    """(N,) robots whose readings may differ between two states of one roster: those whose pose,
    collision flag or wheels differ, and every robot whose sensors or body reach one of them."""
    a = np.column_stack([ahead.x, ahead.y, ahead.heading, ahead.rolled_left, ahead.rolled_right])
    b = np.column_stack([msg.x, msg.y, msg.heading, msg.rolled_left, msg.rolled_right])
    changed = np.asarray(np.any(a != b, axis=1) | (np.asarray(ahead.collided) != np.asarray(msg.collided)), dtype=bool)
    if not changed.any():
        return changed
    bodies = view.bodies_for(list(msg.ids))
    # how far a robot's readings reach from its centre of movement: its outline, its bumpers,
    # its cones (mounting point plus range)
    reach = bodies.bound_radius_m.copy()
    if len(bodies.ir_owner):
        cone = np.hypot(bodies.ir_xy[:, 0], bodies.ir_xy[:, 1]) + bodies.ir_range_m
        np.maximum.at(reach, bodies.ir_owner, cone)
    if len(bodies.bumper_owner):
        bump = np.hypot(bodies.bumper_outline[..., 0], bodies.bumper_outline[..., 1]).max(axis=1)
        np.maximum.at(reach, bodies.bumper_owner, bump)
    out = changed.copy()
    for c in np.flatnonzero(changed):
        for xy in (a[c, :2], b[c, :2]):
            d = np.hypot(b[:, 0] - xy[0], b[:, 1] - xy[1])
            out |= d <= reach + bodies.bound_radius_m[c] + 1e-6
    return out


def _merge(ahead: Computed, again: Computed, which: np.ndarray) -> Computed:
    """The readings computed ahead, with those of robots ``which`` taken from ``again``."""
    redo = {o[1].robot_id: (o, e) for o, e in zip(again.out, again.encoded, strict=True)}
    out: list[tuple[str, SensorReading]] = []
    encoded: list[bytes] = []
    for o, e in zip(ahead.out, ahead.encoded, strict=True):
        o2, e2 = redo.get(o[1].robot_id, (o, e))
        out.append(o2)
        encoded.append(e2)
    enc = np.asarray(np.where(which[:, None], again.enc, ahead.enc), dtype=np.float64)
    return Computed(again.msg, again.ids, out, encoded, enc)


def run(
    bus: Bus,
    sim: str,
    *,
    shard: tuple[int, int] = (1, 1),
    name: str = "sensors",
    io: NodeIO | None = None,
    ahead: bool = True,
) -> None:
    """Computes readings for every committed state until stopped; computes ahead on proposals
    (unless ``ahead`` is false)."""
    io = io or NodeIO(bus, sim, "sensors", name)
    inbox = io.inbox(keys.state(sim))
    proposals = io.inbox(keys.proposed(sim)) if ahead else Inbox()
    cache = InfoCache(bus, sim)
    node: SensorsNode | None = None
    early: Computed | None = None
    ahead_from = 0  # compute ahead from this tick on
    io.alive()
    while not io.stop.is_set():
        pending = inbox.drain()
        if not pending:
            props = proposals.drain()
            if props and node is not None and node.last_tick + 1 >= ahead_from:
                # compute tick n ahead from its proposal while the collision process checks it
                p = io.decode(props[-1], Proposed)
                view = cache.get(p.revision) if p is not None else None
                if p is not None and view is not None and all(i in view.specs for i in p.ids):
                    early = node.ahead(p, view)
                continue
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
            used = early if early is not None and early.msg.tick == msg.tick else None
            c, again = node.settle(used, msg, view)
            early = None
            if used is not None and again > MISSED_AHEAD * max(1, len(c.out)):
                ahead_from = msg.tick + 1 + PAUSE_AHEAD
            t1, c1 = time.perf_counter(), time.process_time()
            for (key, _), data in zip(c.out, c.encoded, strict=True):
                bus.publish(key, data)
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


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz sensors``."""
    return start_role(
        argv,
        role="sensors",
        description=(
            "Computes every robot's sensors each tick (proximity cones, compass, beacons, GPS, "
            "ground, collision, encoders, bumpers)."
        ),
        epilog=(
            "Split the robots between processes or hosts, one shard on each:\n"
            "  iwz sensors --shard 1/2\n"
            "  iwz sensors --shard 2/2 --connect tcp/HOST:7447"
        ),
        arguments=_arguments,
        warm_up=warm_up,  # before joining: the first tick must not wait for a compilation
        prepare=lambda args: parse_shard(args.shard),
        run=lambda proc, shard: run(proc.bus, proc.sim, shard=shard, io=proc.io, ahead=not proc.args.no_ahead),
        name=lambda args: "sensors-{}-{}".format(*parse_shard(args.shard)),
        name_help="sensors-K-N",
    )


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--shard", default="1/1", help="K/N: compute the robots whose id is K modulo N (default 1/1, all)")
    p.add_argument(
        "--no-ahead",
        action="store_true",
        help="do not compute a tick ahead from the world's proposal (the same readings, later; "
        "to compare, or on a machine with one core)",
    )
