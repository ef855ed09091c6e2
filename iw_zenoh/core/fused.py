"""A whole tick in one compiled call: propose, collision check, commit, and every sensor.

:meth:`~iw_zenoh.sim.local.LocalWorld.step_arrays` takes this path for the usual in-process tick
(the native profile, no Real robot, every robot sensed on the caller's thread, no beacons). It
calls, in the order the roles run them, the same compiled functions the separate path calls on
the same values: :func:`~iw_zenoh.core.drive.propose_into` (the world's proposal),
:func:`~iw_zenoh.core.collide._collide` (the collision check), :func:`~iw_zenoh.core.drive.commit_into`
(the commit) and :func:`~iw_zenoh.core.read_all._read` (the sensors), so the states and readings
are the same bit for bit (``tests/sim/test_local_arrays.py`` checks it against the separate path
and against :meth:`~iw_zenoh.sim.local.LocalWorld.step`).

Why: a learning environment's one chair spent about 150 us of a 190 us step in the Python
between those four kernels (each argument converted and checked again, each intermediate result
wrapped in an object, four dispatches): that glue, not arithmetic, kept ChairNav at a few times
ir-sim's speed. Here the arguments that are the same every tick of a roster are built once
(:func:`fixed_args`), and a tick is one dispatch. Cached on disk as the other kernels (``cache=True``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from iw_zenoh.core import read_all
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.collide import _collide, _scene_args
from iw_zenoh.core.drive import commit_into, propose_into
from iw_zenoh.core.lab import Scene
from iw_zenoh.core.read_all import _read

__all__ = ["fixed_args", "tick"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
_NO_NOISE = np.zeros((0, 2))  # no rows: no movement noise
_NO_REPORT = np.zeros((0, 3))  # no rows: no Real robot's report
_NO_HOLD = np.zeros(0, dtype=np.bool_)  # no rows: nobody held
_EVERY = np.zeros(0, dtype=np.bool_)  # the collision kernel's "no mask": every robot takes part


def fixed_args(
    scene: Scene,
    bodies: Bodies,
    table: FloatArray,
    wall_free: BoolArray,
    dt_s: float,
    gps_offset_m: tuple[float, float],
) -> tuple[Any, ...]:
    """The arguments of :func:`tick` that are the same every tick of a roster in a scene, with
    the number of robots and of normals a tick takes, and the sizes of its readings.

    Args:
        scene: The lab.
        bodies: The robots (N >= 1).
        table: (N, 6) the drive's table (:func:`iw_zenoh.core.world._table`).
        wall_free: (N,) robots that pass through walls (doors).
        dt_s: The tick's length.
        gps_offset_m: Added to GPS x and y.
    """
    fixed = read_all._fixed(bodies)
    return (
        bodies.n,
        fixed[0],
        (
            table,
            float(dt_s),
            np.ascontiguousarray(bodies.outline, dtype=np.float64),
            np.ascontiguousarray(wall_free, dtype=np.bool_),
            *_scene_args(scene),
            *read_all._walls(scene),
            *fixed[2:],
            float(gps_offset_m[0]),
            float(gps_offset_m[1]),
        ),
        (len(bodies.ir_owner), int(bodies.lasers.first[len(bodies.lasers.owner)])),
    )  # (robots and normals: to check a tick's arrays against; proximity sensors and beams: its readings' sizes)


def tick(
    pose: FloatArray,
    prev: FloatArray,
    cmd: FloatArray,
    z_motion: FloatArray | None,
    z: FloatArray,
    acc: FloatArray,
    fixed: tuple[Any, ...],
) -> tuple[Any, ...]:
    """One tick of N robots.

    Args:
        pose: (N, 3) the committed poses.
        prev: (N, 2) the motors' outputs.
        cmd: (N, 2) the wheel powers commanded (all three C-contiguous float64).
        z_motion: (N, 2) the tick's standard normals of movement noise, or None: no noise.
        z: The tick's standard normals of the sensors (:func:`~iw_zenoh.core.sensor_noise.noise_layout` order).
        acc: (N, 2) the encoders' counts before the tick.
        fixed: :func:`fixed_args` of the roster.

    Raises:
        ValueError: An array does not fit the roster.

    Returns:
        ``(pose, motor_out, rolled_m, collided, proximity_m, proximity_legacy, compass_deg,
        gps, encoder_acc, laser_m)``: the committed state's arrays, then the readings as
        :func:`~iw_zenoh.core.read_all.read_all` gives them.
    """
    n, normals, args, (m, beams) = fixed
    zm = _NO_NOISE if z_motion is None else np.ascontiguousarray(z_motion, dtype=np.float64)
    # the kernels do not check their indices (a short array would be read past its end)
    if (
        pose.shape != (n, 3)
        or prev.shape != (n, 2)
        or cmd.shape != (n, 2)
        or acc.shape != (n, 2)
        or z.shape != (normals,)
        or zm.shape not in ((0, 2), (n, 2))
    ):
        raise ValueError(
            f"{n} robots, {normals} normals: poses {pose.shape}, motors {prev.shape}, powers {cmd.shape}, "
            f"encoders {acc.shape}, normals {z.shape}, movement noise {zm.shape}"
        )
    # the results go into arrays made here: a kernel's returned array costs about a microsecond
    # to hand back to Python (numba boxes it), and a tick gives ten
    out = (
        np.empty((n, 3)), np.empty((n, 2)), np.empty((n, 2)), np.empty(n, dtype=np.bool_),
        np.empty(m), np.empty(m), np.empty(n), np.empty((n, 3)), np.empty((n, 2)), np.empty(beams),
    )  # fmt: skip
    _tick(pose, prev, cmd, zm, z, acc, *args, *out)
    return out


@njit(cache=True, nogil=True)
def _tick(  # type: ignore[no-untyped-def]  # noqa: ANN202, PLR0913
    pose, prev, cmd, z_motion, z, acc,
    table, dt, outline, wall_free,
    c_segs, c_first, c_count, c_box, c_start, c_items, c_frame,
    gx, gy, cell, nx, ny, segs, seg_box, seg_start, seg_items,
    wall_first, wall_count, wall_box, wall_start, wall_items, seg_side,
    own, ir_xy, ir_angle, ir_half, ir_range,
    l_own, l_xy, l_start, l_step, l_first, l_range, turn_c, turn_s, beam_owner,
    z_prox, z_compass, z_gps, z_enc, z_laser,
    prox_mean, prox_std, legacy_std, laser_mean, laser_std,
    compass_mean, compass_std, gps_mean, gps_std, heading_mean, heading_std,
    slip_mean, slip_std, ticks_per_m,
    off_x, off_y,
    pose2, out2, rolled2, hit, o_prox, o_legacy, o_compass, o_gps, o_enc, o_laser,
):  # fmt: skip  # noqa: ANN001  # pragma: no cover
    n = pose.shape[0]
    # the world's proposal (world.propose: native profile, no report)
    nxt, out, linear, rolled = np.empty((n, 3)), np.empty((n, 2)), np.empty(n), np.empty((n, 2))
    propose_into(pose, prev, cmd, table, dt, False, z_motion, 0.0, _NO_REPORT, nxt, out, linear, rolled)
    # the collision check (collision.check_collisions: every robot, doors pass walls and each other)
    flags = np.empty((3, n), dtype=np.bool_)
    _collide(
        outline, pose, nxt, _EVERY, wall_free, True, flags, c_segs, c_first, c_count, c_box, c_start, c_items, c_frame
    )
    # the commit (world.commit_flags: nobody held), into the caller's arrays
    commit_into(pose, prev, nxt, out, rolled, flags[0], _NO_HOLD, False, pose2, out2, rolled2, hit)
    # the sensors at the committed poses (read_all._read)
    prox, legacy, compass, gps, encoders, laser_m = _read(
        pose2,
        gx, gy, cell, nx, ny, segs, seg_box, seg_start, seg_items,
        wall_first, wall_count, wall_box, wall_start, wall_items, seg_side,
        outline,
        own, ir_xy, ir_angle, ir_half, ir_range,
        l_own, l_xy, l_start, l_step, l_first, l_range, turn_c, turn_s, beam_owner,
        z_prox, z_compass, z_gps, z_enc, z_laser,
        prox_mean, prox_std, legacy_std, laser_mean, laser_std,
        compass_mean, compass_std, gps_mean, gps_std, heading_mean, heading_std,
        slip_mean, slip_std, ticks_per_m,
        z, acc, rolled2, off_x, off_y,
    )  # fmt: skip
    o_prox[:] = prox
    o_legacy[:] = legacy
    o_compass[:] = compass
    o_gps[:] = gps
    o_enc[:] = encoders
    o_laser[:] = laser_m
