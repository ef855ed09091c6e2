"""Every robot's sensors for one tick, in one vectorized call.

Proximity cones return the distance (metres) to the nearest wall or other body inside the cone
and within range, and the Ciber-Rato reading (1/distance rounded to 0.1, 100 when nothing).
Compass, beacons (aperture and wall-height occlusion), GPS, ground (target areas), collision,
wheel encoders (with slip, so odometry drifts) and contact bumpers follow.

Noise: every tick each robot's sensors draw a fixed layout of standard normals from its own
stream, one slot per sensor (:mod:`iw_zenoh.core.sensor_noise`, whose ``noise_layout`` and
``noise_bank`` are re-exported here), so switching one sensor's noise off leaves every other
sensor's noise unchanged, and a robot's readings do not depend on the other robots.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import shapely
from shapely import STRtree

from iw_zenoh.core import readout
from iw_zenoh.core.bodies import Bodies, polygons_at
from iw_zenoh.core.cellgrid import SceneIndex, scene_index
from iw_zenoh.core.cones import cone_distances
from iw_zenoh.core.geometry import to_world, wrap_deg
from iw_zenoh.core.lab import Scene
from iw_zenoh.core.laser import laser_distances
from iw_zenoh.core.legacy_ir import ciberrato_ir_distances
from iw_zenoh.core.placing import outline_at, wedges
from iw_zenoh.core.read_all import read_all
from iw_zenoh.core.sensor_noise import TickNormals, noise_bank, noise_layout, tick_normals

__all__ = [
    "LEGACY_NOTHING",
    "Readings",
    "SensorParams",
    "legacy_ir_value",
    "noise_bank",
    "noise_layout",
    "proximity_distances",
    "read_all_readings",
    "read_sensors",
    "reads_all_at_once",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

LEGACY_NOTHING, LEGACY_MIN_DIST = readout.LEGACY_NOTHING, readout.LEGACY_MIN_DIST  # declared with their kernel


@dataclass(frozen=True)
class SensorParams:
    """Tick-wide sensor settings.

    Attributes:
        beacon_aperture_rad: Half-aperture of beacon sensors (pi: all around).
        gps_offset_m: Constant (x, y) added to GPS positions (Ciber-Rato hides the lab origin).
        threads: The usual tick's cones and laser beams on up to this many of numba's threads
            when there are many robots (:func:`~iw_zenoh.core.read_all.read_all`); the readings
            are the same bits whatever it is.
    """

    beacon_aperture_rad: float = float(np.pi)
    gps_offset_m: tuple[float, float] = (0.0, 0.0)
    threads: int = 1


@dataclass(frozen=True)
class Readings:
    """One tick of readings for N robots with M proximity sensors, B beacons and Bb bumpers.

    Attributes:
        proximity_m: (M,) distance to the nearest thing in each cone, ``inf`` for nothing in range.
        proximity_legacy: (M,) the Ciber-Rato value, 1/d rounded to 0.1 (100 for nothing).
        compass_deg: (N,) heading in [-180, 180).
        beacon_deg: (N, B) bearing relative to the heading, NaN when not visible.
        gps: (N, 3) x, y (m, with offset) and heading (deg).
        ground: (N,) index of the last target area wholly containing the body, or -1.
        collision: (N,) as given by the collision verdict.
        encoder_acc: (N, 2) accumulated encoder ticks (fractional), left and right.
        bumpers: (Bb,) True where a bumper touches a wall or another body.
        laser_m: (L,) every laser beam's range (:mod:`iw_zenoh.core.laser`), ``inf`` for nothing
            within range.
    """

    proximity_m: FloatArray
    proximity_legacy: FloatArray
    compass_deg: FloatArray
    beacon_deg: FloatArray
    gps: FloatArray
    ground: IntArray
    collision: BoolArray
    encoder_acc: FloatArray
    bumpers: BoolArray
    laser_m: FloatArray

    @property
    def encoder_ticks(self) -> IntArray:
        """(N, 2) whole encoder ticks, as a real encoder counts them."""
        return np.floor(self.encoder_acc).astype(np.int64)


def legacy_ir_value(distance: FloatArray, z: FloatArray, std: FloatArray) -> FloatArray:
    """Ciber-Rato's IR value: ``floor(10 * (ideal + std * z) + 0.5) / 10``, not clamped.

    Args:
        distance: (M,) distances in lab units, ``inf`` for no hit.
        z: (M,) standard normals.
        std: (M,) noise deviation (ObstacleNoise).

    Returns:
        (M,) readings, ideal ``1/d`` for ``d > 0.01`` and 100 otherwise.
    """
    ok = np.isfinite(distance) & (distance > LEGACY_MIN_DIST)
    ideal = np.where(ok, 1.0 / np.where(ok, distance, 1.0), LEGACY_NOTHING)
    return np.asarray(np.floor(10.0 * (ideal + std * z) + 0.5) / 10.0, dtype=np.float64)


def proximity_distances(
    scene: Scene, bodies: Bodies, pose: FloatArray, *, only: BoolArray | None = None, index: SceneIndex | None = None
) -> FloatArray:
    """The true distance seen by every proximity cone of every robot.

    Args:
        scene: The lab's geometry.
        bodies: The robots.
        pose: (N, 3) poses.
        only: (N,) compute the sensors of these robots only (a sensor shard); every robot is
            still an obstacle to them. The others read ``inf``.
        index: :func:`~iw_zenoh.core.cellgrid.scene_index` of ``scene`` and the bodies at ``pose``,
            when the caller has it already.

    Returns:
        (M,) distance from each sensor's mounting point to the nearest point of a wall, the border
        or another robot's body inside its cone; ``inf`` when that is beyond its range.
    """
    m = len(bodies.ir_owner)
    if m == 0:
        return np.zeros(0)
    if only is not None and not np.all(only):
        sel = np.asarray(only, dtype=bool)[bodies.ir_owner]
        out = np.full(m, np.inf)
        if sel.any():
            out[sel] = _proximity(scene, bodies, pose, np.flatnonzero(sel), index)
        return out
    return _proximity(scene, bodies, pose, np.arange(m), index)


def _proximity(
    scene: Scene, bodies: Bodies, pose: FloatArray, sensors: IntArray, index: SceneIndex | None
) -> FloatArray:
    pose = np.ascontiguousarray(pose, dtype=np.float64)
    own = bodies.ir_owner[sensors]
    # the compiled _wedge_normals and _wedge_bounds (core.placing, the same numbers)
    ox, oy, normals, lo, hi = wedges(
        pose, own, sensors, bodies.ir_xy, bodies.ir_angle_rad, bodies.ir_half_cone_rad, bodies.ir_range_m
    )
    ix = scene_index(scene, outline_at(bodies.outline, pose)) if index is None else index
    return cone_distances(scene, ox, oy, normals, bodies.ir_range_m[sensors], lo, hi, own, ix.body_xy, index=ix)


def _ground(scene: Scene, bodies: Bodies, pose: FloatArray) -> IntArray:
    if not scene.lab.targets or len(pose) == 0:
        out = np.empty(len(pose), dtype=np.int64)
        out.fill(-1)  # on no target (np.full's value, for half its cost)
        return out
    out = np.full(len(pose), -1, dtype=np.int64)
    t = scene.target_array  # (T, 3): x, y, radius
    # a body can only be wholly inside a target whose radius covers the body's centre
    ri, ti = scene.target_tree.query(shapely.points(pose[:, 0], pose[:, 1]))
    centre = np.hypot(pose[ri, 0] - t[ti, 0], pose[ri, 1] - t[ti, 1])
    ok = centre <= t[ti, 2]
    ri, ti, centre = ri[ok], ti[ok], centre[ok]
    if len(ri) == 0:
        return out
    corners = to_world(bodies.outline[ri], pose[ri, 0], pose[ri, 1], pose[ri, 2])
    far = np.hypot(corners[..., 0] - t[ti, 0:1], corners[..., 1] - t[ti, 1:2]).max(axis=1)
    far = np.where(bodies.is_circle[ri], centre + bodies.radius_m[ri], far)
    ok = far <= t[ti, 2]
    # the last target wins: write in target order so later ones overwrite earlier ones
    order = np.argsort(ti[ok], kind="stable")
    out[ri[ok][order]] = ti[ok][order]
    return out


def _beacons(
    scene: Scene,
    pose: FloatArray,
    z: FloatArray,
    mean: FloatArray,
    std: FloatArray,
    aperture: float,
    moving: tuple[tuple[int, float], ...] = (),
) -> FloatArray:
    """Bearings to the lab's beacons, then to the beacons robots carry (``moving``: robot index
    and height; the carrier does not see its own)."""
    if not scene.lab.beacons and not moving:  # none (a learner's room): no lists to build
        return np.full((len(pose), 0), np.nan)
    fixed = [(bc.x, bc.y, bc.height_m, -1) for bc in scene.lab.beacons]
    carried = [(float(pose[i, 0]), float(pose[i, 1]), h, i) for i, h in moving]
    n = len(pose)
    out = np.full((n, len(fixed) + len(carried)), np.nan)
    for j, (bx, by, height, carrier) in enumerate(fixed + carried):
        dx = bx - pose[:, 0]
        dy = by - pose[:, 1]
        true = np.degrees(np.arctan2(dy, dx) - pose[:, 2])
        val = wrap_deg(true + mean + std * z[:, j])
        lines = shapely.linestrings(np.stack([pose[:, :2], np.broadcast_to([bx, by], (n, 2))], axis=1))
        blocked = shapely.intersects(lines, scene.walls_at_least(height))
        visible = ~blocked & (np.abs(val) <= np.degrees(aperture))
        if carrier >= 0:
            visible[carrier] = False
        out[:, j] = np.where(visible, val, np.nan)
    return out


def _bumpers(scene: Scene, bodies: Bodies, pose: FloatArray) -> BoolArray:
    nb = len(bodies.bumper_owner)
    if nb == 0:
        return np.zeros(0, dtype=bool)
    own = bodies.bumper_owner
    bp = polygons_at(bodies.bumper_outline, pose[own])
    out = np.zeros(nb, dtype=bool)
    pw = scene.solid_tree.query(bp, predicate="intersects")
    out[pw[0]] = True
    others = polygons_at(bodies.outline, pose)
    pr = STRtree(others).query(bp, predicate="intersects")
    out[pr[0][pr[1] != own[pr[0]]]] = True
    return out


def _seen_distances(
    scene: Scene, bodies: Bodies, pose: FloatArray, *, only: BoolArray | None, legacy_ir: bool, index: SceneIndex
) -> tuple[FloatArray, FloatArray]:
    """The true distance of every proximity sensor and the one its legacy reading comes from.

    Returns:
        ``(true_d, legacy_d)``, both (M,); the same array unless ``legacy_ir`` (Ciber-Rato's own
        model, three rays and corners, gives the legacy distance, and the whole reading of discs).
    """
    own = bodies.ir_owner
    if not (legacy_ir and len(own)):
        true_d = proximity_distances(scene, bodies, pose, only=only, index=index)
        return true_d, true_d
    slots = bodies.ir_slots
    angles = np.where(slots >= 0, bodies.ir_angle_rad[np.maximum(slots, 0)], 0.0)
    grid = ciberrato_ir_distances(scene, pose, angles)
    legacy_d = np.full(len(own), np.inf)
    legacy_d[slots[slots >= 0]] = grid[slots >= 0]
    # Ciber-Rato's disc robots see by its own model only (their rim sensors have no range, so
    # the cone model would test every body against every sensor for the same answer)
    cones = ~bodies.is_circle if only is None else np.asarray(only, dtype=bool) & ~bodies.is_circle
    true_d = proximity_distances(scene, bodies, pose, only=cones, index=index)
    discs = bodies.is_circle[own]
    true_d[discs] = legacy_d[discs]
    if only is not None:
        true_d[~np.asarray(only, dtype=bool)[own]] = np.inf
    return true_d, legacy_d


def read_all_readings(
    scene: Scene,
    bodies: Bodies,
    pose: FloatArray,
    collided: BoolArray,
    proximity_m: FloatArray,
    proximity_legacy: FloatArray,
    compass_deg: FloatArray,
    gps: FloatArray,
    encoder_acc: FloatArray,
    laser_m: FloatArray,
) -> Readings:
    """The readings of a tick whose sensors :func:`~iw_zenoh.core.read_all.read_all` computed
    (or the fused tick, :mod:`iw_zenoh.core.fused`): its arrays, with the ground and bumpers.

    Built as its constructor builds it, without the frozen dataclass's ``object.__setattr__``
    per field (a learning environment's chair makes one a step)."""
    n = len(pose)
    r = object.__new__(Readings)
    r.__dict__.update(
        proximity_m=proximity_m,
        proximity_legacy=proximity_legacy,
        compass_deg=compass_deg,
        beacon_deg=np.empty((n, 0)),  # no beacons: no values (what np.full gives)
        gps=gps,
        ground=_ground(scene, bodies, pose),
        collision=np.array(collided, dtype=np.bool_),
        encoder_acc=encoder_acc,
        bumpers=_bumpers(scene, bodies, pose),
        laser_m=laser_m,
    )
    return r


def reads_all_at_once(
    scene: Scene, bodies: Bodies, *, every: bool, legacy_ir: bool, moving_beacons: tuple[tuple[int, float], ...]
) -> bool:
    """Whether :func:`read_sensors` computes a tick's sensors in one compiled call
    (:func:`~iw_zenoh.core.read_all.read_all`), which the fused tick (:mod:`iw_zenoh.core.fused`)
    runs too: ``every`` robot computed (no shard), without Ciber-Rato's IR model, no beacon in
    the lab or carried by a robot, at least one robot."""
    return every and not legacy_ir and not scene.lab.beacons and not moving_beacons and bodies.n > 0


def read_sensors(
    scene: Scene,
    bodies: Bodies,
    pose: FloatArray,
    *,
    collided: BoolArray,
    encoder_acc: FloatArray,
    rolled_m: FloatArray,
    z: FloatArray,
    params: SensorParams | None = None,
    only: BoolArray | None = None,
    legacy_ir: bool = False,
    moving_beacons: tuple[tuple[int, float], ...] = (),
) -> Readings:
    """Computes every sensor of every robot for one tick.

    Args:
        scene: The lab's geometry.
        bodies: The robots (N).
        pose: (N, 3) committed poses.
        collided: (N,) this tick's collision flags.
        encoder_acc: (N, 2) encoder ticks accumulated before this tick.
        rolled_m: (N, 2) distance each wheel rolled this tick.
        z: This tick's standard normals in :func:`noise_layout` order (from each robot's own
            sensor stream, e.g. a :class:`~iw_zenoh.core.noise.NoiseBank`).
        params: Tick-wide settings.
        only: (N,) robots whose proximity sensors to compute (a shard); others read ``inf``.
        legacy_ir: Compute the legacy reading with Ciber-Rato's own IR model (three rays,
            corners, its robot formula) instead of from the exact cone distance.
        moving_beacons: Beacons robots carry, as (robot index, height), after the lab's in
            ``beacon_deg`` (and in the noise layout: count them in ``n_beacons``).

    Returns:
        The readings.
    """
    p = params or SensorParams()
    if only is not None and np.all(only):
        only = None  # every robot (the usual shard of one): what None means, without the selections
    if reads_all_at_once(scene, bodies, every=only is None, legacy_ir=legacy_ir, moving_beacons=moving_beacons):
        # the usual tick in one compiled call (core.read_all: the same functions, the same numbers)
        got = read_all(scene, bodies, pose, z, encoder_acc, rolled_m, p.gps_offset_m, p.threads)
        return read_all_readings(scene, bodies, pose, collided, *got)
    return _separately(scene, bodies, pose, collided, encoder_acc, rolled_m, z, p, only, legacy_ir, moving_beacons)


def _separately(
    scene: Scene,
    bodies: Bodies,
    pose: FloatArray,
    collided: BoolArray,
    encoder_acc: FloatArray,
    rolled_m: FloatArray,
    z: FloatArray,
    p: SensorParams,
    only: BoolArray | None,
    legacy_ir: bool,
    moving_beacons: tuple[tuple[int, float], ...],
) -> Readings:
    """:func:`read_sensors` sensor kind after sensor kind (a shard, Ciber-Rato's IR, beacons)."""
    nm, ns = bodies.noise_mean, bodies.noise_std
    z_of = tick_normals(bodies, z, len(scene.lab.beacons) + len(moving_beacons))
    # the bodies at their poses, binned once for the cones and the scanners
    ix = scene_index(scene, outline_at(bodies.outline, np.ascontiguousarray(pose, dtype=np.float64)))
    true_d, legacy_d = _seen_distances(scene, bodies, pose, only=only, legacy_ir=legacy_ir, index=ix)
    prox, legacy, compass, gps, encoders = _noisy(bodies, pose, z_of, true_d, legacy_d, encoder_acc, rolled_m, p)
    beacon = _beacons(
        scene, pose, z_of.beacon, nm["beacon_deg"], ns["beacon_deg"], p.beacon_aperture_rad, moving_beacons
    )
    ranges = laser_distances(scene, bodies, pose, only=only, index=ix)
    return Readings(
        proximity_m=prox,
        proximity_legacy=legacy,
        compass_deg=compass,
        beacon_deg=beacon,
        gps=gps,
        ground=_ground(scene, bodies, pose),
        collision=np.asarray(collided, dtype=bool).copy(),
        encoder_acc=encoders,
        bumpers=_bumpers(scene, bodies, pose),
        laser_m=readout.noisy_ranges(ranges, z_of.laser, bodies.lasers.beam_owner, nm["laser_m"], ns["laser_m"]),
    )


def _noisy(
    bodies: Bodies,
    pose: FloatArray,
    z_of: TickNormals,
    true_d: FloatArray,
    legacy_d: FloatArray,
    encoder_acc: FloatArray,
    rolled_m: FloatArray,
    p: SensorParams,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """The noisy proximity (metres and legacy), compass, GPS and encoder readings, compiled
    (core.readout: the numpy expressions' numbers, bit for bit)."""
    nm, ns = bodies.noise_mean, bodies.noise_std
    prox, legacy = readout.noisy_proximity(
        _f64(true_d),
        _f64(legacy_d),
        z_of.proximity,
        bodies.ir_owner,
        nm["proximity_m"],
        ns["proximity_m"],
        ns["proximity_legacy"],
    )
    compass, gps = readout.pose_readings(
        _f64(pose),
        z_of.compass,
        z_of.gps,
        (float(p.gps_offset_m[0]), float(p.gps_offset_m[1])),
        (nm["compass_deg"], ns["compass_deg"]),
        (nm["gps_m"], ns["gps_m"]),
        (nm["gps_heading_deg"], ns["gps_heading_deg"]),
    )
    encoders = readout.encoders(
        _f64(encoder_acc), _f64(rolled_m), bodies.ticks_per_m, z_of.encoder, nm["encoder_slip"], ns["encoder_slip"]
    )
    return prox, legacy, compass, gps, encoders


def _f64(a: npt.ArrayLike) -> FloatArray:
    return np.ascontiguousarray(a, dtype=np.float64)
