"""Conversions between the core's data (specs, labs, grids) and their wire shapes.

The wire shapes are :mod:`iw_zenoh.messages`'; the core's are :mod:`iw_zenoh.core`'s. Each pair
is named after what it converts: ``spec_from_msg`` / ``spec_to_msg`` and so on. A spec coming in
is checked here (``RobotSpec`` refuses a value out of range, naming the field).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import msgspec

from iw_zenoh.core.spec import (
    BodyShape,
    BumperSpec,
    EncoderSpec,
    IrSensorSpec,
    LaserSpec,
    NoiseSpec,
    RobotSpec,
    RobotType,
    SensorNoise,
    check_counts,
)
from iw_zenoh.errors import SpecError
from iw_zenoh.messages import (
    BumperMsg,
    IrSensorMsg,
    LabMsg,
    LaserMsg,
    NoiseMsg,
    RobotSpecMsg,
    SensorNoiseMsg,
    WallMsg,
)

if TYPE_CHECKING:  # the lab's geometry (numpy, shapely) is imported by what converts a lab, not by every spec reader
    from iw_zenoh.core.lab import Grid, Lab

__all__ = ["grid_from_msg", "grid_to_msg", "lab_from_msg", "lab_to_msg", "spec_from_msg", "spec_to_msg"]


def _noise(m: NoiseMsg | None | msgspec.UnsetType, default: NoiseSpec) -> NoiseSpec:
    return NoiseSpec(m.mean, m.std, m.enabled) if isinstance(m, NoiseMsg) else default


def spec_from_msg(m: RobotSpecMsg) -> RobotSpec:
    """Turns a wire spec into a checked core spec.

    Raises:
        SpecError: Naming the field that is out of range.
    """
    d = SensorNoise()
    n = m.noise
    noise = d
    if n is not None:
        noise = SensorNoise(
            _noise(n.proximity_m, d.proximity_m),
            _noise(n.proximity_legacy, d.proximity_legacy),
            _noise(n.compass_deg, d.compass_deg),
            _noise(n.beacon_deg, d.beacon_deg),
            _noise(n.gps_m, d.gps_m),
            _noise(n.gps_heading_deg, d.gps_heading_deg),
            _noise(n.encoder_slip, d.encoder_slip),
            _noise(n.motion, d.motion),
            _noise(n.laser_m, d.laser_m),
        )
    for name in ("width_m", "height_m", "com", "max_speed_mps", "acceleration_curve", "ticks_per_m"):
        v = getattr(m, name)
        if not math.isfinite(v):
            raise SpecError(name, f"must be a finite number, got {v!r}")
    # a hostile count is refused before a single sensor is built
    check_counts(len(m.ir_sensors), len(m.lasers) if isinstance(m.lasers, list) else 0, len(m.bumpers))
    return RobotSpec(
        name=m.name,
        id=m.id,
        type=RobotType(m.type),
        shape=BodyShape(m.shape),
        width_m=m.width_m,
        height_m=m.height_m,
        com=m.com,
        x_m=m.x_m,
        y_m=m.y_m,
        dir_deg=m.dir_deg,
        max_speed_mps=m.max_speed_mps,
        acceleration_curve=m.acceleration_curve,
        ir_sensors=tuple(IrSensorSpec(s.id, s.x_m, s.y_m, s.angle_deg, s.cone_deg, s.range_m) for s in m.ir_sensors),
        bumpers=tuple(BumperSpec(b.id, tuple(b.corners)) for b in m.bumpers),
        lasers=tuple(
            LaserSpec(s.id, s.x_m, s.y_m, s.angle_deg, s.fov_deg, s.beams, s.range_m)
            for s in (m.lasers if isinstance(m.lasers, list) else ())
        ),
        encoder=EncoderSpec(m.ticks_per_m),
        noise=noise,
        legacy=m.legacy,
        beacon_height_m=m.beacon_height_m,
    )


def _noise_msg(n: NoiseSpec) -> NoiseMsg:
    return NoiseMsg(mean=n.mean, std=n.std, enabled=n.enabled)


def spec_to_msg(s: RobotSpec) -> RobotSpecMsg:
    """Turns a core spec into its wire shape (sensors listed explicitly)."""
    n = s.noise
    return RobotSpecMsg(
        name=s.name,
        id=s.id,
        type=s.type.value,
        shape=s.shape.value,
        width_m=s.width_m,
        height_m=s.height_m,
        com=s.com,
        x_m=s.x_m,
        y_m=s.y_m,
        dir_deg=s.dir_deg,
        max_speed_mps=s.max_speed_mps,
        acceleration_curve=s.acceleration_curve,
        ir_sensors=[
            IrSensorMsg(id=i.id, x_m=i.x_m, y_m=i.y_m, angle_deg=i.angle_deg, cone_deg=i.cone_deg, range_m=i.range_m)
            for i in s.sensors
        ],
        bumpers=[BumperMsg(id=b.id, corners=list(b.corners)) for b in s.bumpers],
        ticks_per_m=s.encoder.ticks_per_m,
        noise=SensorNoiseMsg(
            proximity_m=_noise_msg(n.proximity_m),
            proximity_legacy=_noise_msg(n.proximity_legacy),
            compass_deg=_noise_msg(n.compass_deg),
            beacon_deg=_noise_msg(n.beacon_deg),
            gps_m=_noise_msg(n.gps_m),
            gps_heading_deg=_noise_msg(n.gps_heading_deg),
            encoder_slip=_noise_msg(n.encoder_slip),
            motion=_noise_msg(n.motion),
            # written only when it matters, so a spec without a scanner reads as before it existed
            laser_m=_noise_msg(n.laser_m) if s.lasers or n.laser_m != SensorNoise().laser_m else msgspec.UNSET,
        ),
        legacy=s.legacy,
        beacon_height_m=s.beacon_height_m,
        lasers=[
            LaserMsg(
                id=a.id,
                x_m=a.x_m,
                y_m=a.y_m,
                angle_deg=a.angle_deg,
                fov_deg=a.fov_deg,
                beams=a.beams,
                range_m=a.range_m,
            )
            for a in s.lasers
        ]
        or msgspec.UNSET,
    )


def lab_to_msg(lab: Lab) -> LabMsg:
    """The wire shape of a lab."""
    return LabMsg(
        name=lab.name,
        width=lab.width_m,
        height=lab.height_m,
        walls=[WallMsg(corners=list(w.corners), height=w.height_m) for w in lab.walls],
        beacons=[(b.x, b.y, b.height_m) for b in lab.beacons],
        targets=[(t.x, t.y, t.radius_m) for t in lab.targets],
    )


def lab_from_msg(m: LabMsg) -> Lab:
    """A lab from its wire shape."""
    from iw_zenoh.core.lab import Beacon, Lab, Target, Wall  # here: an agent that reads specs never loads shapely

    return Lab(
        m.name,
        m.width,
        m.height,
        tuple(Wall(tuple(w.corners), w.height) for w in m.walls),
        tuple(Beacon(*b) for b in m.beacons),
        tuple(Target(*t) for t in m.targets),
    )


def grid_to_msg(grid: Grid) -> list[tuple[float, float, float]]:
    """The wire shape of a grid: (x, y, dir_deg) rows."""
    return [(p.x, p.y, p.dir_deg) for p in grid.positions]


def grid_from_msg(rows: list[tuple[float, float, float]]) -> Grid:
    """A grid from its wire shape."""
    from iw_zenoh.core.lab import Grid, GridPosition

    return Grid(tuple(GridPosition(*r) for r in rows))
