"""The sensors' logic: every robot's readings each tick, for one shard of the robots.

A shard ``(K, N)`` computes the robots whose id is K modulo N (K from 1), so several sensor
processes, on several hosts, split the robots; every robot is still an obstacle to every sensor.
Noise comes from each robot's own seeded stream, so a robot's readings are the same whichever
shard computes them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache
from operator import attrgetter
from typing import NamedTuple

import msgspec
import numpy as np

from iw_zenoh import keys
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.noise import NoiseStreams, Stream
from iw_zenoh.core.read_all import PARALLEL_FROM
from iw_zenoh.core.sensors import Readings, SensorParams, noise_layout, read_sensors, reads_all_at_once
from iw_zenoh.messages import LaserScan, Outgoing, Proposed, SensorReading, WorldState, encode
from iw_zenoh.sim.early import state_from_proposal
from iw_zenoh.sim.view import ROSTERS_KEPT, WorldView

__all__ = ["Computed", "SensorsNode", "state_from_proposal"]  # state_from_proposal: from sim.early

_PARAMS = SensorParams()  # the sensors' tick-wide settings (the defaults; frozen)
ALL_AGAIN = 0.25  # when this share of robots is touched, all are computed again (no merging)


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


class SensorsNode:
    """Computes the readings of one shard's robots from a committed state (logic only).

    It may also compute ahead from the world's proposal of tick n (:meth:`ahead`) while the
    collision process checks it; when the committed state then equals the proposal (nothing
    collided, nothing held) those readings are the state's, bit for bit, and go out at once
    (:meth:`settle`). Robots that collided, and robots whose sensors reach them, are computed
    again from the state. Noise is drawn once per tick however often a tick is computed.

    When the collision verdict confirms the proposal (:func:`iw_zenoh.sim.early.confirms`), the
    readings computed ahead go out before the state (:meth:`send_early`); the state then only
    checks them (:meth:`check_early`), and corrects the rare tick the world held after all.

    Args:
        sim: Simulation name.
        seed: The run's seed (each robot's sensor stream derives from it).
        shard: ``(K, N)``.
        threads: Compute the cones and laser beams on up to this many threads when there are
            many robots (:func:`~iw_zenoh.core.read_all.read_all`; the same readings). The
            distributed role keeps 1: it shares the machine with every other role, and a
            parallel step waits for its slowest thread.
    """

    def __init__(self, sim: str, seed: int = 0, shard: tuple[int, int] = (1, 1), *, threads: int = 1) -> None:
        self.sim = sim
        self._params = _PARAMS if threads == 1 else SensorParams(threads=threads)
        self.seed = seed
        self.shard = shard
        self.last_tick = -1  # the newest tick whose readings went out
        self._noise = NoiseStreams(seed, Stream.SENSORS, threads=threads)
        self._z: tuple[int, list[int], np.ndarray] | None = None  # (tick, roster, its normals)
        self._enc_ids: list[int] = []  # the roster of the last tick, and its encoder counts
        self._enc = np.zeros((0, 2))
        self._keys: dict[int, str] = {}  # robot id -> its sensors key (built once)
        self.early: Computed | None = None  # readings that went out before their state
        self._undo: tuple[list[int], np.ndarray, tuple[int, list[int], np.ndarray] | None, int] | None = None
        self.corrections = 0  # ticks whose early readings the state proved wrong
        self._layout: _Layout | None = None

    @property
    def params(self) -> SensorParams:
        """The tick-wide settings the node computes with."""
        return self._params

    def warm(self, view: WorldView) -> None:
        """Computes the view's robots once, where they were placed, in a throwaway node (its own
        noise streams and encoder counts: this node's stay untouched, so a run is the same warm
        or not), so that what a roster's first readings build (its bodies, the lab's structures
        for the rays) is built before the revision's first state waits on it: in real time the
        first readings after a robot registered came about a second late."""
        robots = [r for r in view.info.robots if r.id in view.specs]
        if not robots:
            return
        n = len(robots)
        probe = WorldState(
            tick=0,
            sim_time_ns=0,
            revision=view.info.revision,
            ids=[r.id for r in robots],
            x=[view.info.lab.width / 2 if r.x_m is None else r.x_m for r in robots],
            y=[view.info.lab.height / 2 if r.y_m is None else r.y_m for r in robots],
            heading=[0.0] * n,
            collided=[False] * n,
            rolled_left=[0.0] * n,
            rolled_right=[0.0] * n,
            speed=[0.0] * n,
        )
        SensorsNode(self.sim, self.seed, self.shard).compute(probe, view)

    def on_state(self, msg: WorldState, view: WorldView) -> list[Outgoing]:
        """Every reading of this shard's robots for tick n (computed and committed)."""
        c = self.compute(msg, view)
        self.commit(c)
        return list(c.out)

    def ahead(self, proposal: Proposed, view: WorldView) -> Computed | None:
        """Readings of tick n computed from its proposal (not committed), or None when the
        previous tick's readings are not out yet (encoder counts would be stale), or when it does
        not say how far the wheels rolled (an older world's), or while the state of readings that
        went out early is not checked yet (a correction would make this tick's start stale)."""
        if (
            self.early is not None
            or self.last_tick >= 0
            and proposal.tick != self.last_tick + 1
            or len(proposal.rolled_left) != len(proposal.ids)
        ):
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

    def send_early(self, ahead: Computed) -> None:
        """Commits readings computed ahead whose proposal the verdict confirmed, so they go out
        before the state; what they replace is kept until the state says they were right."""
        self._undo = (self._enc_ids, self._enc, self._z, self.last_tick)
        self.commit(ahead)
        self.early = ahead

    def check_early(self, msg: WorldState, view: WorldView) -> Computed | None:
        """The committed state of the tick whose readings went out early: None when they are its
        readings (the usual case); otherwise (the world held the tick: the verdict came after its
        deadline) the readings that differ, computed as :meth:`settle` would have and committed in
        place of the early ones (the same noise: a tick's normals are drawn once)."""
        sent, undo = self.early, self._undo
        assert sent is not None
        assert undo is not None
        assert sent.msg.tick == msg.tick
        self.early = self._undo = None
        if _same_frame(sent.msg, msg) and not _touched(sent.msg, msg, view).any():
            return None
        self._enc_ids, self._enc, self._z, self.last_tick = undo
        c, _ = self.settle(sent, msg, view)
        self.corrections += 1
        if c.ids != sent.ids:  # not a roster the world can change within a tick: all of them
            return c
        pairs = zip(c.out, c.encoded, sent.encoded, strict=True)
        differ = [(o, e) for o, e, was in pairs if e != was]
        return replace(c, out=[o for o, _ in differ], encoded=[e for _, e in differ]) if differ else None

    def forget_early(self) -> None:
        """The state of the tick that went out early never came (a newer one did): they stand."""
        self.early = self._undo = None

    def commit(self, c: Computed) -> None:
        """Makes ``c`` the newest tick: its encoder counts are the next tick's start (and the keys
        of robots that left are forgotten: the table holds the roster, not every robot ever)."""
        if c.ids != self._enc_ids and len(self._keys) > len(c.ids):
            roster = set(c.ids)
            self._keys = {rid: key for rid, key in self._keys.items() if rid in roster}
        self.commit_counts(c.msg.tick, c.ids, c.enc)

    def commit_counts(self, tick: int, ids: list[int], enc: np.ndarray) -> None:
        """Makes tick ``tick`` of robots ``ids`` the newest, with its (N, 2) encoder counts."""
        self._enc_ids, self._enc = ids, enc
        self.last_tick = tick
        if self._z is not None and self._z[0] <= tick:
            self._z = None

    def _normals(self, tick: int, ids: list[int], counts: list[int], starts: list[int], only: list[bool]) -> np.ndarray:
        """This tick's standard normals, drawn once per tick (a tick computed again reuses them)."""
        if self._z is not None and self._z[0] == tick and self._z[1] == ids:
            return self._z[2]
        z = np.zeros(int(sum(counts)))
        self._noise.fill(ids, counts, starts, only, z)
        self._z = (tick, ids, z)
        return z

    def compute(self, msg: WorldState, view: WorldView, subset: np.ndarray | None = None) -> Computed:
        """Readings of this shard's robots for ``msg`` (of ``subset`` only, if given), not committed."""
        ids = list(msg.ids)
        if not ids:
            return Computed(msg, ids, [], [], np.zeros((0, 2)))
        bodies = view.bodies_for(ids)
        pose = np.column_stack([msg.x, msg.y, msg.heading])
        rolled = np.column_stack([msg.rolled_left, msg.rolled_right])
        r, only, enc = self.read(
            msg.tick, ids, bodies, pose, np.asarray(msg.collided, dtype=bool), rolled, view, subset
        )
        out = self._readings(msg, ids, bodies, r, only)
        # each reading is encoded once: on its robot's key and inside the shard's batch
        encoded = [encode(m) for _, m in out]
        return Computed(msg, ids, out, encoded, enc)

    def read(
        self,
        tick: int,
        ids: list[int],
        bodies: Bodies,
        pose: np.ndarray,
        collided: np.ndarray,
        rolled: np.ndarray,
        view: WorldView,
        subset: np.ndarray | None = None,
    ) -> tuple[Readings, np.ndarray, np.ndarray]:
        """The readings of tick ``tick`` as arrays (what :meth:`compute` turns into messages), from
        (N, 3) poses, (N,) collision flags and (N, 2) distances rolled, robots ``ids`` (``bodies``):
        the readings, the robots computed, and the encoder counts after the tick (not committed:
        :meth:`commit_counts`)."""
        lay = self._roster(view, ids, bodies)
        only = lay.mine if subset is None else lay.mine & subset
        z = self._normals(tick, ids, lay.counts, lay.starts, lay.mine_list)
        enc = self._encoders(ids)
        r = read_sensors(
            view.scene,
            bodies,
            pose,
            collided=collided,
            encoder_acc=enc,
            rolled_m=rolled,
            z=z,
            params=self._params,
            only=None if subset is None and lay.all_mine else only,  # None: every robot, without a test
            legacy_ir=view.info.profile == Profile.CIBERRATO,
            moving_beacons=lay.moving,
        )
        if subset is None and lay.all_mine:  # every robot's count moves on (np.where's values, without the test)
            return r, only, r.encoder_acc.copy()
        return r, only, np.where(only[:, None], r.encoder_acc, enc)

    def fused_inputs(
        self, tick: int, ids: list[int], bodies: Bodies, view: WorldView
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """What a tick computed in one call (:mod:`iw_zenoh.core.fused`) takes of this node: the
        tick's normals and the (N, 2) encoder counts before it; None when the tick is not one
        :meth:`read` computes with :func:`~iw_zenoh.core.read_all.read_all` on the caller's
        thread (a shard, beacons, Ciber-Rato's IR model, sensors on threads). Commit the counts
        after (:meth:`commit_counts`), as after :meth:`read`."""
        lay = self._roster(view, ids, bodies)
        legacy = view.info.profile == Profile.CIBERRATO  # read() asks for Ciber-Rato's IR model so
        if not reads_all_at_once(view.scene, bodies, every=lay.all_mine, legacy_ir=legacy, moving_beacons=lay.moving):
            return None
        if self._params.threads > 1 and bodies.n >= PARALLEL_FROM:  # read_all's threads: its parallel kernel
            return None
        return self._normals(tick, ids, lay.counts, lay.starts, lay.mine_list), self._encoders(ids)

    def _roster(self, view: WorldView, ids: list[int], bodies: Bodies) -> _Layout:
        """This shard's robots (read-only), the beacons robots carry, and the noise layout of a
        roster: the same every tick, worked out again only when its bodies change (a view builds
        one per roster, so the same bodies are the same view and robots)."""
        if self._layout is None or self._layout.bodies is not bodies:
            k, n = self.shard
            mine = np.asarray(ids, dtype=np.int64) % n == k % n
            mine.setflags(write=False)
            # robots that carry a beacon (Ciber-Rato's RobotBeacon), in id order after the lab's
            moving = tuple((i, h) for i, rid in enumerate(ids) if (h := view.specs[rid].beacon_height_m) is not None)
            counts, starts = noise_layout(bodies, len(view.scene.lab.beacons) + len(moving))
            self._layout = _Layout(
                bodies, mine, moving, counts.tolist(), starts.tolist(), mine.tolist(), bool(mine.all())
            )
        return self._layout

    def _encoders(self, ids: list[int]) -> np.ndarray:
        """(N, 2) encoder counts before this tick, for roster ``ids``."""
        if ids == self._enc_ids:
            return self._enc
        # the roster changed: carry each remaining robot's count over
        before = {rid: row for rid, row in zip(self._enc_ids, self._enc.tolist(), strict=True)}
        return np.asarray([before.get(rid, (0.0, 0.0)) for rid in ids], dtype=np.float64).reshape(-1, 2)

    def _readings(
        self, msg: WorldState, ids: list[int], bodies: Bodies, r: Readings, only: np.ndarray
    ) -> list[tuple[str, SensorReading]]:
        """One message per robot of ``only``, with its key, from the arrays of ``r``."""
        out: list[tuple[str, SensorReading]] = []
        # whole arrays to Python lists once; each robot's sensors are a contiguous run
        m_first, m_last, b_first, b_last, pids = _runs(bodies)
        prox = np.where(np.isfinite(r.proximity_m), r.proximity_m, np.nan).tolist()
        prox = [None if v != v else v for v in prox]  # NaN (nothing in range) -> null
        legacy = r.proximity_legacy.tolist()
        beacons = [[None if v != v else v for v in row] for row in r.beacon_deg.tolist()]
        gps = r.gps.tolist()
        compass = r.compass_deg.tolist()
        ground = r.ground.tolist()
        collision = r.collision.tolist()
        ticks = r.encoder_ticks.tolist()
        bumpers = r.bumpers.tolist()
        lasers = _scans(bodies, r, len(ids))
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
                lasers=lasers[i],
            )
            key = self._keys.get(rid)
            if key is None:
                key = self._keys[rid] = keys.sensors(self.sim, rid)
            out.append((key, reading))
        return out


class _Layout(NamedTuple):
    """A roster's shard and noise layout (the same every tick: worked out when its bodies change)."""

    bodies: Bodies
    mine: np.ndarray  # (N,) this shard's robots, read-only
    moving: tuple[tuple[int, float], ...]  # the beacons robots carry: (robot index, height)
    counts: list[int]  # normals a robot draws a tick
    starts: list[int]  # where its normals start
    mine_list: list[bool]  # mine, as fill takes it
    all_mine: bool  # every robot is this shard's


class _Runs(NamedTuple):
    """Where each robot's sensors are in a roster's arrays (lists, shared: sliced, never changed)."""

    m_first: list[int]  # robot i's proximity sensors are [m_first[i], m_last[i])
    m_last: list[int]
    b_first: list[int]  # its bumpers [b_first[i], b_last[i])
    b_last: list[int]
    pids: list[int]  # each proximity sensor's id


@lru_cache(maxsize=ROSTERS_KEPT)
def _runs(bodies: Bodies) -> _Runs:
    """The runs of :class:`_Runs`, worked out once per roster (the same every tick)."""
    robots = np.arange(bodies.n)
    return _Runs(
        np.searchsorted(bodies.ir_owner, robots).tolist(),
        np.searchsorted(bodies.ir_owner, robots, side="right").tolist(),
        np.searchsorted(bodies.bumper_owner, robots).tolist(),
        np.searchsorted(bodies.bumper_owner, robots, side="right").tolist(),
        bodies.ir_id.tolist(),
    )


def _scans(bodies: Bodies, r: Readings, n: int) -> list[list[LaserScan] | msgspec.UnsetType]:
    """Each robot's laser scans (unset for a robot without a scanner: its reading's JSON stays as
    it was before scanners existed)."""
    out: list[list[LaserScan] | msgspec.UnsetType] = [msgspec.UNSET] * n
    lz = bodies.lasers
    if not len(lz.owner):
        return out
    ranges = [None if v == math.inf else v for v in r.laser_m.tolist()]
    first = lz.first.tolist()
    for s, (i, sid) in enumerate(zip(lz.owner.tolist(), lz.id.tolist(), strict=True)):
        scans = out[i]
        if not isinstance(scans, list):
            scans = out[i] = []
        scans.append(LaserScan(id=sid, ranges=ranges[first[s] : first[s + 1]]))
    return out


def _same_frame(a: WorldState, b: WorldState) -> bool:
    """Whether two states of one tick share everything but poses, flags and distances rolled."""
    return (a.tick, a.sim_time_ns, a.revision, a.tick_wall_ns, a.ids) == (
        b.tick,
        b.sim_time_ns,
        b.revision,
        b.tick_wall_ns,
        b.ids,
    )


_MOVES = attrgetter("x", "y", "heading", "rolled_left", "rolled_right", "collided")  # what _touched compares


def _touched(ahead: WorldState, msg: WorldState, view: WorldView) -> np.ndarray:
    """(N,) robots whose readings may differ between two states of one roster: those whose pose,
    collision flag or wheels differ, and every robot whose sensors or body reach one of them."""
    if _MOVES(ahead) == _MOVES(msg):  # the usual case, without arrays (JSON has no NaN: equal lists, equal values)
        return np.zeros(len(msg.ids), dtype=bool)
    a = np.column_stack([ahead.x, ahead.y, ahead.heading, ahead.rolled_left, ahead.rolled_right])
    b = np.column_stack([msg.x, msg.y, msg.heading, msg.rolled_left, msg.rolled_right])
    changed = np.asarray(np.any(a != b, axis=1) | (np.asarray(ahead.collided) != np.asarray(msg.collided)), dtype=bool)
    if not changed.any():
        return changed
    bodies = view.bodies_for(list(msg.ids))
    # how far a robot's readings reach from its centre of movement: its outline, its bumpers,
    # its cones and laser scanners (mounting point plus range)
    reach = bodies.bound_radius_m.copy()
    if len(bodies.ir_owner):
        cone = np.hypot(bodies.ir_xy[:, 0], bodies.ir_xy[:, 1]) + bodies.ir_range_m
        np.maximum.at(reach, bodies.ir_owner, cone)
    lz = bodies.lasers
    if len(lz.owner):
        np.maximum.at(reach, lz.owner, np.hypot(lz.xy[:, 0], lz.xy[:, 1]) + lz.range_m)
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
