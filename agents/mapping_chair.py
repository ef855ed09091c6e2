"""The chair an autonomous driver maps with, and its readings as cones in the world.

Its eight 60-degree sonars cannot tell where along a corridor-wide arc a thing is, so the chair
:mod:`iw_zenoh.agents.autopilot` drives carries narrow cones instead (re-exported there).
"""

from __future__ import annotations

import math

from iw_zenoh.core.sonarmap import Cone
from iw_zenoh.core.spec import IrSensorSpec, RobotSpec, prototype_chair

from .waypoint import FINE_GPS

__all__ = ["MAPPING_SENSORS", "cones_of", "mapping_chair"]

MAPPING_SENSORS = tuple(
    IrSensorSpec(i, x, y, a, 5.0, 3.0)
    for i, (x, y, a) in enumerate(
        [(0.8, 0.1 * k, 0.0) for k in range(-3, 4)]
        + [(0.8, math.copysign(0.33, a), a) for a in (-15.0, 15.0, -30.0, 30.0, -45.0, 45.0, -60.0, 60.0, -75.0, 75.0)]
        + [(x, math.copysign(0.33, a), a) for x in (0.5, 0.2, -0.1) for a in (-90.0, 90.0)]
        + [(-0.2, 0.0, 180.0)]
    )
)  # twenty-four narrow (5-degree) infrared rangefinders, 3 m: seven ahead, ten round the front
# corners, six along the sides, one behind


def mapping_chair(name: str, **overrides: object) -> RobotSpec:
    """The LIACC prototype's body with the narrow cones an autonomous chair maps with (its
    eight 60-degree sonars cannot tell where along a corridor-wide arc a thing is) and a fine
    GPS (a localised chair)."""
    args: dict[str, object] = {"ir_sensors": MAPPING_SENSORS, "noise": FINE_GPS}
    args.update(overrides)
    return prototype_chair(name, **args)  # type: ignore[arg-type]


def cones_of(
    spec: RobotSpec, pose: tuple[float, float, float], ids: list[int], dists: list[float | None]
) -> list[Cone]:
    """The cones of a reading in world coordinates (pose: x, y, heading deg)."""
    x, y, hdg = pose
    th = math.radians(hdg)
    c, s = math.cos(th), math.sin(th)
    by_id = {m.id: m for m in spec.sensors}
    out = []
    for i, d in zip(ids, dists, strict=True):
        m = by_id.get(i)
        if m is None:
            continue
        out.append(
            Cone(
                x + c * m.x_m - s * m.y_m,
                y + s * m.x_m + c * m.y_m,
                th + math.radians(m.angle_deg),
                math.radians(m.cone_deg) / 2,
                m.range_m,
                d,
            )
        )
    return out
