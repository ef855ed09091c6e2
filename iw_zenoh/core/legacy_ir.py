"""Ciber-Rato's IR (obstacle) sensor model, exactly as the legacy simulator computes it (fact
sheet section 7.5), for the ``ciberrato`` profile.

Sensor i of a disc robot sits on its rim at p = centre + 0.5 (cos(theta + a_i), sin(theta + a_i))
and looks along phi = theta + a_i. Its distance d is the smallest of: three rays (phi and
phi +- 30 deg) to the nearest wall edge; the distance to every wall corner whose bearing from p
is within 30 deg of phi; and, for every other robot at distance D from p, D - 0.5 when its
bearing is within 30 deg, D cos(psi) - sqrt(0.25 - (D sin(psi))^2) when it is within 30 deg
plus asin(0.5 / D) (psi the excess over 30 deg), nothing otherwise.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from iw_zenoh.core.lab import Scene

__all__ = ["HALF_CONE", "ciberrato_ir_distances"]

FloatArray = npt.NDArray[np.float64]

HALF_CONE = np.pi / 6  # +-30 deg
RADIUS = 0.5  # the robots' disc radius
RAY_EPS = 1e-12  # a ray parallel to a segment never hits it
ROBOT_BLOCK = 64  # other robots per vectorised block (bounds the temporaries at N x K x 64)


def _wrap(a: FloatArray) -> FloatArray:
    return np.asarray((a + np.pi) % (2 * np.pi) - np.pi, dtype=np.float64)


def ciberrato_ir_distances(
    scene: Scene, pose: FloatArray, angles_rad: FloatArray, *, active: npt.NDArray[np.bool_] | None = None
) -> FloatArray:
    """Distances seen by every IR sensor of every disc robot (``inf`` when nothing is seen).

    Args:
        scene: The lab (walls and border).
        pose: (N, 3) robot centres and headings.
        angles_rad: (N, K) each robot's sensor mounting angles.
        active: (N,) robots that are obstacles to the others (not Removed); default all.

    Returns:
        (N, K) distances.
    """
    n, k = angles_rad.shape
    act = np.ones(n, dtype=bool) if active is None else np.asarray(active, dtype=bool)
    phi = pose[:, 2:3] + angles_rad  # (N, K)
    px = pose[:, 0:1] + RADIUS * np.cos(phi)
    py = pose[:, 1:2] + RADIUS * np.sin(phi)
    best = _nearer_wall_edges(scene, px, py, phi, np.full((n, k), np.inf))
    best = _nearer_wall_corners(scene, px, py, phi, best)
    return _nearer_robots(pose, px, py, phi, np.flatnonzero(act), best)


def _nearer_wall_edges(scene: Scene, px: FloatArray, py: FloatArray, phi: FloatArray, best: FloatArray) -> FloatArray:
    """``best`` lowered to where each sensor's three rays (phi, phi +- 30 deg) first meet a wall
    edge (the border included); ``px``, ``py``, ``phi`` and ``best`` are (N, K)."""
    seg = scene.segments  # (S, 2, 2)
    ax, ay = seg[:, 0, 0], seg[:, 0, 1]
    ex, ey = seg[:, 1, 0] - ax, seg[:, 1, 1] - ay
    for off in (-HALF_CONE, 0.0, HALF_CONE):
        dx = np.cos(phi + off)[..., None]
        dy = np.sin(phi + off)[..., None]
        wx = ax - px[..., None]
        wy = ay - py[..., None]
        denom = dx * ey - dy * ex  # cross(d, e)
        ok = np.abs(denom) > RAY_EPS
        safe = np.where(ok, denom, 1.0)
        t = (wx * ey - wy * ex) / safe  # along the ray
        u = (wx * dy - wy * dx) / safe  # along the segment
        hit = ok & (t >= 0.0) & (u >= 0.0) & (u <= 1.0)
        best = np.minimum(best, np.where(hit, t, np.inf).min(axis=-1))
    return best


def _nearer_wall_corners(scene: Scene, px: FloatArray, py: FloatArray, phi: FloatArray, best: FloatArray) -> FloatArray:
    """``best`` lowered to the distance of every wall corner within 30 deg of each sensor's axis."""
    cx, cy = scene.corners[:, 0], scene.corners[:, 1]
    vx = cx - px[..., None]
    vy = cy - py[..., None]
    within = np.abs(_wrap(np.arctan2(vy, vx) - phi[..., None])) <= HALF_CONE
    return np.asarray(np.minimum(best, np.where(within, np.hypot(vx, vy), np.inf).min(axis=-1)), dtype=np.float64)


def _nearer_robots(
    pose: FloatArray, px: FloatArray, py: FloatArray, phi: FloatArray, others: npt.NDArray[np.intp], best: FloatArray
) -> FloatArray:
    """``best`` lowered to what each sensor sees of the robots ``others`` (indices into ``pose``),
    by the legacy formula for a disc in or at the rim of the cone; a robot never sees itself.

    A block of robots at a time (N x K x block arrays). The angle tests are done on cosines and
    sines (dot and cross products) rather than with atan2 / asin: the same conditions without a
    transcendental function per pair.
    """
    ux, uy = np.cos(phi)[..., None], np.sin(phi)[..., None]
    ch, sh = np.cos(HALF_CONE), np.sin(HALF_CONE)
    for b0 in range(0, len(others), ROBOT_BLOCK):
        j = others[b0 : b0 + ROBOT_BLOCK]
        vx = pose[j, 0][None, None, :] - px[..., None]  # (N, K, B)
        vy = pose[j, 1][None, None, :] - py[..., None]
        dist = np.sqrt(vx * vx + vy * vy)
        with np.errstate(invalid="ignore", divide="ignore"):
            cos_d = (vx * ux + vy * uy) / dist  # cos and |sin| of delta, the bearing off phi
            sin_d = np.abs(vx * uy - vy * ux) / dist
            in_cone = cos_d >= ch  # delta <= 30 deg
            # delta <= 30 deg + asin(R / D): cos(delta) >= cos(30 deg + m)
            sin_m = np.minimum(1.0, RADIUS / dist)
            cos_m = np.sqrt(1.0 - sin_m * sin_m)
            on_rim = cos_d >= ch * cos_m - sh * sin_m
            cos_psi = cos_d * ch + sin_d * sh  # psi = delta - 30 deg
            sin_psi = sin_d * ch - cos_d * sh
            inner = np.maximum(0.0, RADIUS**2 - (dist * sin_psi) ** 2)
            side = dist * cos_psi - np.sqrt(inner)
        d = np.where(in_cone, dist - RADIUS, np.where(on_rim, side, np.inf))
        d[j, :, np.arange(len(j))] = np.inf  # a robot does not see itself
        best = np.minimum(best, d.min(axis=-1))
    return np.asarray(best, dtype=np.float64)
