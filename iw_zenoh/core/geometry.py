"""Plane geometry shared by the core: angles, poses and robot body outlines.

Frame: x to the right, y up, headings in radians counter-clockwise from +x, as in
Ciber-Rato. Every function here is vectorized over leading array dimensions.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = [
    "CIRCLE_SEGMENTS",
    "body_outline",
    "circle_outline",
    "rect_outline",
    "to_world",
    "wrap_deg",
    "wrap_rad",
]

FloatArray = npt.NDArray[np.float64]

CIRCLE_SEGMENTS = 24  # a circle body as a 24-gon: 0.9 % short of the radius at worst


def wrap_rad(angle_rad: npt.ArrayLike) -> FloatArray:
    """Wraps angles into [-pi, pi).

    Args:
        angle_rad: Angles in radians, any shape.

    Returns:
        The same angles wrapped into [-pi, pi), as float64.
    """
    a = np.asarray(angle_rad, dtype=np.float64)
    return np.asarray((a + np.pi) % (2.0 * np.pi) - np.pi, dtype=np.float64)


def wrap_deg(angle_deg: npt.ArrayLike) -> FloatArray:
    """Wraps angles into [-180, 180).

    Args:
        angle_deg: Angles in degrees, any shape.

    Returns:
        The same angles wrapped into [-180, 180), as float64.
    """
    a = np.asarray(angle_deg, dtype=np.float64)
    return np.asarray((a + 180.0) % 360.0 - 180.0, dtype=np.float64)


def to_world(local_xy: FloatArray, x: FloatArray, y: FloatArray, heading_rad: FloatArray) -> FloatArray:
    """Maps points from each robot's frame to the world frame.

    Args:
        local_xy: Points in the robot frames, shape (N, K, 2), metres.
        x: Robot x, shape (N,), metres.
        y: Robot y, shape (N,), metres.
        heading_rad: Robot heading, shape (N,), radians.

    Returns:
        The points in the world frame, shape (N, K, 2).
    """
    c = np.cos(heading_rad)[:, None]
    s = np.sin(heading_rad)[:, None]
    lx = local_xy[..., 0]
    ly = local_xy[..., 1]
    out = np.empty(local_xy.shape, dtype=np.float64)
    out[..., 0] = x[:, None] + c * lx - s * ly
    out[..., 1] = y[:, None] + s * lx + c * ly
    return out


def rect_outline(width_m: FloatArray, height_m: FloatArray, com: FloatArray) -> FloatArray:
    """The corners of rectangular bodies in their own frame (origin at the centre of movement).

    Counter-clockwise from the front right corner; Table 4.1 of the seed names the same four
    points as corners 1, 0, 2, 3.

    Args:
        width_m: Length along the heading, shape (N,).
        height_m: Size across the heading, shape (N,).
        com: Centre of movement as a fraction of width from the rear, shape (N,).

    Returns:
        Corners, shape (N, 4, 2).
    """
    front = com * width_m
    rear = -(1.0 - com) * width_m
    half = 0.5 * height_m
    return np.stack(
        [
            np.stack([front, -half], axis=-1),
            np.stack([front, half], axis=-1),
            np.stack([rear, half], axis=-1),
            np.stack([rear, -half], axis=-1),
        ],
        axis=1,
    )


def circle_outline(radius_m: FloatArray, segments: int = CIRCLE_SEGMENTS) -> FloatArray:
    """Regular polygons inscribed in circles centred on each robot's origin.

    Args:
        radius_m: Radii, shape (N,).
        segments: Number of vertices.

    Returns:
        Vertices, shape (N, segments, 2), counter-clockwise.
    """
    t = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    unit = np.stack([np.cos(t), np.sin(t)], axis=-1)
    return np.asarray(np.asarray(radius_m, dtype=np.float64)[:, None, None] * unit[None, :, :], dtype=np.float64)


def body_outline(
    width_m: FloatArray, height_m: FloatArray, com: FloatArray, is_circle: npt.NDArray[np.bool_]
) -> FloatArray:
    """Outlines of mixed rectangle and circle bodies, padded to a common vertex count.

    A rectangle repeats its last corner to fill the shape so every row has the same length;
    repeated vertices do not change the polygon.

    Args:
        width_m: Length along the heading (a circle's diameter), shape (N,).
        height_m: Size across the heading, shape (N,).
        com: Centre of movement fraction, shape (N,).
        is_circle: True for circular bodies, shape (N,).

    Returns:
        Vertices in each robot's frame, shape (N, K, 2) with K = 4 when there is no circle, else
        ``CIRCLE_SEGMENTS``.
    """
    rect = rect_outline(width_m, height_m, com)
    if not np.any(is_circle):
        return rect
    k = CIRCLE_SEGMENTS
    out = np.concatenate([rect, np.repeat(rect[:, 3:4, :], k - 4, axis=1)], axis=1)
    circ = circle_outline(0.5 * width_m, k)
    out[is_circle] = circ[is_circle]
    return out
