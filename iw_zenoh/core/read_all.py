"""The usual tick's cones, laser scanners and noisy readings in one compiled call.

:func:`~iw_zenoh.core.sensors.read_sensors` takes this path when every robot is computed (no
sensor shard), without Ciber-Rato's IR model and without beacons: the bodies placed and binned,
the cones' wedges and distances, the scanners' mounting points and ranges, the tick's normals cut
into each sensor's slots, and the noisy proximity, compass, GPS, encoder and laser readings. It
calls the same compiled functions the separate path calls (:mod:`iw_zenoh.core.placing`,
:mod:`iw_zenoh.core.cellgrid`, :mod:`iw_zenoh.core.cones`, :mod:`iw_zenoh.core.laser`,
:mod:`iw_zenoh.core.readout`) on the same values, so the readings are the same bit for bit
(``tests/core/test_read_all.py`` checks it against the separate path on random worlds).

Why: on a learning environment's one chair the separate path was a dozen compiled calls, each
paying numba's dispatch, the unboxing of the scene's index (a tuple of arrays: ~4 us a call) and
the boxing of every array it returned (~0.5 us each, ``numba.core.serialize._numba_unpickle``
in a profile), plus the numpy glue between them: ~150 us a tick, most of it not arithmetic.
Cached on disk as the other kernels (``cache=True``).
"""

from __future__ import annotations

from functools import lru_cache

import numba
import numpy as np
import numpy.typing as npt
from numba import njit, prange

from iw_zenoh.core import cones, laser, readout
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.cellgrid import CellGrid, SceneIndex, SceneWalls, _boxes, _flat, _index, bin_boxes, scene_walls
from iw_zenoh.core.lab import Lab, Scene, Wall
from iw_zenoh.core.placing import mounts, outline_at, wedges
from iw_zenoh.core.sensor_noise import ROSTERS_KEPT, _slots, noise_layout
from iw_zenoh.core.spec import LaserSpec, prototype_chair

__all__ = ["PARALLEL_FROM", "read_all", "warm_up"]

FloatArray = npt.NDArray[np.float64]
_CACHE_KEY = "read_all_walls"  # where a scene keeps its walls as the kernel's arguments
IntArray = npt.NDArray[np.int64]
# below this many robots a tick's sensors cost less than starting numba's threads on them
PARALLEL_FROM = 16


def read_all(
    scene: Scene,
    bodies: Bodies,
    pose: FloatArray,
    z: FloatArray,
    encoder_acc: FloatArray,
    rolled_m: FloatArray,
    gps_offset_m: tuple[float, float],
    threads: int = 1,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Every robot's noisy cones, compass, GPS, encoders and laser beams (no beacons).

    Args:
        scene: The lab's geometry.
        bodies: The robots (N >= 1).
        pose: (N, 3) poses.
        z: This tick's standard normals in :func:`~iw_zenoh.core.sensor_noise.noise_layout` order
            (no beacons).
        encoder_acc: (N, 2) encoder ticks before this tick.
        rolled_m: (N, 2) distance each wheel rolled this tick.
        gps_offset_m: Added to GPS x and y.
        threads: Compute the cones and the laser beams on up to this many of numba's threads
            when there are at least :data:`PARALLEL_FROM` robots (1: on the caller's; the
            readings are the same bits either way).

    Returns:
        ``(proximity_m, proximity_legacy, compass_deg, gps, encoder_acc, laser_m)`` as
        :class:`~iw_zenoh.core.sensors.Readings` holds them.
    """
    pose = np.ascontiguousarray(pose, dtype=np.float64)
    z = np.ascontiguousarray(z, dtype=np.float64)
    acc = np.ascontiguousarray(encoder_acc, dtype=np.float64)
    rolled = np.ascontiguousarray(rolled_m, dtype=np.float64)
    n, fixed = bodies.n, _fixed(bodies)
    # the kernel does not check its indices (a short array would be read past its end)
    if pose.shape != (n, 3) or acc.shape != (n, 2) or rolled.shape != (n, 2) or z.shape != (fixed[0],):
        raise ValueError(
            f"{n} robots: poses {pose.shape}, encoders {acc.shape}, rolled {rolled.shape}, normals {z.shape}"
        )
    walls, off = _walls(scene), (float(gps_offset_m[0]), float(gps_offset_m[1]))
    parts = _parts(threads, n)
    if parts == 1:
        return _read(pose, *walls, *fixed[1:], z, acc, rolled, *off)  # type: ignore[no-any-return, call-arg]
    # on threads: the index, the parallel loop, the noise (three calls: the serial kernel does
    # not reference the parallel one, whose first compilation takes half a minute)
    outline, sensed, beam_owner, noise = fixed[1], fixed[2:15], fixed[15], fixed[16:]
    own, l_first = np.asarray(sensed[0]), np.asarray(sensed[9])
    ix = _index_at(pose, *walls, outline)  # type: ignore[call-arg]
    true_d, ranges = np.empty(len(own)), np.full(int(l_first[-1]), np.inf)
    _sense_parallel(parts, pose, *sensed, *_flat(ix), true_d, ranges)  # type: ignore[call-arg]
    return _noisy(true_d, ranges, pose, own, beam_owner, *noise, z, acc, rolled, *off)  # type: ignore[no-any-return, call-arg]


def _parts(threads: int, n: int) -> int:
    """How many runs of sensors the kernel computes on threads (1: none, the serial kernels)."""
    if threads <= 1 or n < PARALLEL_FROM:
        return 1
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))  # type: ignore[attr-defined]
    return threads


def _walls(scene: Scene) -> tuple[object, ...]:
    """The scene's wall index as the kernel's arguments (kept in the scene's cache beside it)."""
    w = scene_walls(scene)
    got = scene._cache.get(_CACHE_KEY)
    if isinstance(got, tuple) and got[0] is w:
        return got[1:]
    g = w.grid
    args: tuple[object, ...] = (g.x0, g.y0, g.cell, g.nx, g.ny, w.segs, w.seg_box, w.seg_start, w.seg_items)
    args = (*args, w.wall_first, w.wall_count, w.wall_box, w.wall_start, w.wall_items, w.seg_side)
    scene._cache[_CACHE_KEY] = (w, *args)
    return args


@lru_cache(maxsize=ROSTERS_KEPT)
def _fixed(bodies: Bodies) -> tuple[object, ...]:
    """The normals a tick of this roster takes, then its arrays as the kernel's arguments (the
    same every tick: worked out once)."""
    s = _slots(bodies, 0)
    nm, ns = bodies.noise_mean, bodies.noise_std
    lz = bodies.lasers
    return (
        int(noise_layout(bodies, 0)[0].sum()),  # the normals a tick takes (not an argument)
        bodies.outline,
        bodies.ir_owner, bodies.ir_xy, bodies.ir_angle_rad, bodies.ir_half_cone_rad, bodies.ir_range_m,
        lz.owner, lz.xy, lz.start_rad, lz.step_rad, lz.first, lz.range_m, *laser.beam_turns(lz.step_rad, lz.first),
        lz.beam_owner,
        s.proximity, s.compass, s.gps, s.encoder, s.laser,
        nm["proximity_m"], ns["proximity_m"], ns["proximity_legacy"], nm["laser_m"], ns["laser_m"],
        nm["compass_deg"], ns["compass_deg"], nm["gps_m"], ns["gps_m"], nm["gps_heading_deg"], ns["gps_heading_deg"],
        nm["encoder_slip"], ns["encoder_slip"], bodies.ticks_per_m,
    )  # fmt: skip


@njit(cache=True, nogil=True)
def _take2(z: FloatArray, idx: IntArray) -> FloatArray:  # pragma: no cover
    """``z[idx]`` for a 2-D index array."""
    out = np.empty(idx.shape)
    for i in range(idx.shape[0]):
        for j in range(idx.shape[1]):
            out[i, j] = z[idx[i, j]]
    return out


@njit(cache=True, nogil=True)
def _read(  # type: ignore[no-untyped-def]  # noqa: ANN202, PLR0913
    pose,
    gx, gy, cell, nx, ny, segs, seg_box, seg_start, seg_items,
    wall_first, wall_count, wall_box, wall_start, wall_items, seg_side,
    outline,
    own, ir_xy, ir_angle, ir_half, ir_range,
    l_own, l_xy, l_start, l_step, l_first, l_range, turn_c, turn_s, beam_owner,
    z_prox, z_compass, z_gps, z_enc, z_laser,
    prox_mean, prox_std, legacy_std, laser_mean, laser_std,
    compass_mean, compass_std, gps_mean, gps_std, heading_mean, heading_std,
    slip_mean, slip_std, ticks_per_m,
    z, acc, rolled, off_x, off_y,
):  # fmt: skip  # noqa: ANN001  # pragma: no cover
    ix = _index_at(
        pose, gx, gy, cell, nx, ny, segs, seg_box, seg_start, seg_items,
        wall_first, wall_count, wall_box, wall_start, wall_items, seg_side, outline,
    )  # fmt: skip
    # the cones (sensors._proximity) and the scanners (laser.laser_distances), every one
    true_d = np.empty(own.shape[0])
    ranges = np.full(l_first[l_own.shape[0]], np.inf)
    _sense_part(
        0, 1, pose, own, ir_xy, ir_angle, ir_half, ir_range, l_own, l_xy, l_start, l_step, l_first, l_range,
        turn_c, turn_s, ix, true_d, ranges,
    )  # fmt: skip
    return _noisy(
        true_d, ranges, pose, own, beam_owner, z_prox, z_compass, z_gps, z_enc, z_laser,
        prox_mean, prox_std, legacy_std, laser_mean, laser_std,
        compass_mean, compass_std, gps_mean, gps_std, heading_mean, heading_std,
        slip_mean, slip_std, ticks_per_m, z, acc, rolled, off_x, off_y,
    )  # fmt: skip


@njit(cache=True, nogil=True)
def _index_at(  # type: ignore[no-untyped-def]  # noqa: ANN202, PLR0913
    pose,
    gx, gy, cell, nx, ny, segs, seg_box, seg_start, seg_items,
    wall_first, wall_count, wall_box, wall_start, wall_items, seg_side,
    outline,
):  # fmt: skip  # noqa: ANN001  # pragma: no cover
    """The scene's walls and the bodies placed at ``pose`` and binned: what the kernels search."""
    g = CellGrid(gx, gy, cell, nx, ny)
    w = SceneWalls(
        g, segs, seg_box, seg_start, seg_items, wall_first, wall_count, wall_box, wall_start, wall_items, seg_side
    )
    body_xy = outline_at(outline, pose)
    bbox = _boxes(body_xy)
    b_start, b_items = bin_boxes(bbox, g.x0, g.y0, g.cell, g.nx, g.ny)
    return SceneIndex(w, body_xy, bbox, b_start, b_items)


@njit(cache=True, nogil=True)
def _noisy(  # type: ignore[no-untyped-def]  # noqa: ANN202, PLR0913
    true_d, ranges, pose, own, beam_owner,
    z_prox, z_compass, z_gps, z_enc, z_laser,
    prox_mean, prox_std, legacy_std, laser_mean, laser_std,
    compass_mean, compass_std, gps_mean, gps_std, heading_mean, heading_std,
    slip_mean, slip_std, ticks_per_m,
    z, acc, rolled, off_x, off_y,
):  # fmt: skip  # noqa: ANN001  # pragma: no cover
    """The readings from the true distances and this tick's normals (sensor_noise.tick_normals,
    then sensors._noisy and readout.noisy_ranges)."""
    prox, legacy = readout.noisy_proximity(true_d, true_d, z[z_prox], own, prox_mean, prox_std, legacy_std)
    compass, gps = readout.pose_readings(
        pose,
        z[z_compass],
        _take2(z, z_gps),
        (off_x, off_y),
        (compass_mean, compass_std),
        (gps_mean, gps_std),
        (heading_mean, heading_std),
    )
    encoders = readout.encoders(acc, rolled, ticks_per_m, _take2(z, z_enc), slip_mean, slip_std)
    laser_m = readout.noisy_ranges(ranges, z[z_laser], beam_owner, laser_mean, laser_std)
    return prox, legacy, compass, gps, encoders, laser_m


@njit(cache=True, nogil=True)
def _sense_part(  # type: ignore[no-untyped-def]  # noqa: ANN202, PLR0913
    p, parts,
    pose, own, ir_xy, ir_angle, ir_half, ir_range, l_own, l_xy, l_start, l_step, l_first, l_range, turn_c, turn_s,
    ix, true_d, ranges,
):  # fmt: skip  # noqa: ANN001  # pragma: no cover
    """Run ``p`` of ``parts`` of the cones and of the scanners (each cut into ``parts`` runs of
    neighbours): their wedges or mounting points, then their distances, written to ``true_d``
    and ``ranges``. Every sensor's values are the same arithmetic on the same values whatever
    the run it falls in."""
    m = own.shape[0]
    c0, c1 = p * m // parts, (p + 1) * m // parts
    if c1 > c0:
        ox, oy, nrm, lo, hi = wedges(pose, own[c0:c1], np.arange(c0, c1), ir_xy, ir_angle, ir_half, ir_range)
        box = np.empty((c1 - c0, 4))
        box[:, :2] = lo
        box[:, 2:] = hi
        cones._scan_part(0, c1 - c0, ox, oy, nrm, ir_range[c0:c1], box, own[c0:c1], ix, true_d[c0:c1])
    ns = l_own.shape[0]
    s0, s1 = p * ns // parts, (p + 1) * ns // parts
    if s1 > s0:
        lx, ly = mounts(pose, l_own[s0:s1], l_xy, np.arange(s0, s1))
        start = np.empty(s1 - s0)
        for t in range(s1 - s0):
            start[t] = pose[l_own[s0 + t], 2] + l_start[s0 + t]
        first = l_first[s0 : s1 + 1]  # the beams' places in ranges, as they are
        laser._scan_part(
            0, s1 - s0, lx, ly, start, l_step[s0:s1], first, l_range[s0:s1], l_own[s0:s1], ix, turn_c, turn_s, ranges
        )


@njit(cache=True, nogil=True, parallel=True)
def _sense_parallel(  # type: ignore[no-untyped-def]  # noqa: ANN202, PLR0913
    parts,
    pose, own, ir_xy, ir_angle, ir_half, ir_range, l_own, l_xy, l_start, l_step, l_first, l_range, turn_c, turn_s,
    gx, gy, cell, nx, ny, segs, seg_box, seg_start, seg_items, w_first, w_count,
    w_box, w_start, w_items, side, body_xy, bbox, b_start, b_items,
    true_d, ranges,
):  # fmt: skip  # noqa: ANN001  # pragma: no cover
    """Every run of :func:`_sense_part` on numba's threads (the scene's index comes flat: a
    parallel loop takes arrays and numbers, not tuples of them)."""
    for p in prange(parts):  # noqa: PLE1133 (numba's parallel range)
        ix = _index(
            gx, gy, cell, nx, ny, segs, seg_box, seg_start, seg_items, w_first, w_count,
            w_box, w_start, w_items, side, body_xy, bbox, b_start, b_items,
        )  # fmt: skip
        _sense_part(
            p, parts, pose, own, ir_xy, ir_angle, ir_half, ir_range, l_own, l_xy, l_start, l_step, l_first, l_range,
            turn_c, turn_s, ix, true_d, ranges,
        )  # fmt: skip


def warm_up() -> None:
    """Compiles the kernel now (or loads it from the cache), so the first tick is not slow."""
    scene = Scene(Lab("warm-up", 4.0, 4.0, (Wall(((1.0, 1.0), (2.0, 1.0), (2.0, 2.0)), 1.0),)))
    spec = prototype_chair(
        "warm-up", lasers=(LaserSpec(id=0, x_m=0.5, angle_deg=0.0, fov_deg=270.0, beams=4, range_m=3.0),)
    )
    bodies = Bodies.from_specs([spec])
    counts, _ = noise_layout(bodies, 0)
    read_all(
        scene,
        bodies,
        np.asarray([[3.0, 3.0, 0.0]]),
        np.zeros(int(counts.sum())),
        np.zeros((1, 2)),
        np.zeros((1, 2)),
        (0.0, 0.0),
    )
