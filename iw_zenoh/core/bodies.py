"""Robot bodies as arrays: the static per-robot data every tick needs, built once from specs.

A :class:`Bodies` holds outlines, drive constants and flattened sensor layouts for N robots in
a fixed order (index ``i`` is ``ids[i]``). Poses are kept apart, as ``(N, 3)`` arrays of
x (m), y (m) and heading (rad), since they change every tick.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt
import shapely

from iw_zenoh.core.geometry import body_outline, to_world
from iw_zenoh.core.motor import DriveParams
from iw_zenoh.core.spec import BodyShape, BumperSpec, NoiseSpec, RobotSpec, RobotType

__all__ = ["Bodies", "Lasers", "polygons_at"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]


def _noise_arrays(specs: Sequence[NoiseSpec]) -> tuple[FloatArray, FloatArray]:
    mean = np.asarray([s.mean if s.enabled else 0.0 for s in specs], dtype=np.float64)
    std = np.asarray([s.std if s.enabled else 0.0 for s in specs], dtype=np.float64)
    return mean, std


def _noise_by_kind(specs: Sequence[RobotSpec]) -> tuple[dict[str, FloatArray], dict[str, FloatArray]]:
    """Each sensor kind's noise bias and deviation, (N,) arrays keyed by kind (0 where off)."""
    kinds = {
        "proximity_m": [s.noise.proximity_m for s in specs],
        "proximity_legacy": [s.noise.proximity_legacy for s in specs],
        "compass_deg": [s.noise.compass_deg for s in specs],
        "beacon_deg": [s.noise.beacon_deg for s in specs],
        "gps_m": [s.noise.gps_m for s in specs],
        "gps_heading_deg": [s.noise.gps_heading_deg for s in specs],
        "encoder_slip": [s.noise.encoder_slip for s in specs],
        "motion": [s.noise.motion for s in specs],
        "laser_m": [s.noise.laser_m for s in specs],
    }
    means: dict[str, FloatArray] = {}
    stds: dict[str, FloatArray] = {}
    for k, v in kinds.items():
        means[k], stds[k] = _noise_arrays(v)
    return means, stds


def _bumper_outlines(bumpers: Sequence[BumperSpec]) -> FloatArray:
    """(B, Kb, 2) bumper polygons, the shorter ones padded by repeating their last corner."""
    kb = max((len(b.corners) for b in bumpers), default=3)
    out = np.zeros((len(bumpers), kb, 2), dtype=np.float64)
    for j, b in enumerate(bumpers):
        c = np.asarray(b.corners, dtype=np.float64)
        out[j, : len(c)] = c
        out[j, len(c) :] = c[-1]
    return out


@dataclass(frozen=True, eq=False)
class Lasers:
    """The laser scanners of N robots, flattened (S scanners, L beams in all), sorted by robot.

    Attributes:
        owner: (S,) index of the robot of each scanner.
        id: (S,) scanner ids.
        xy: (S, 2) mounting points in the robot frame, metres.
        start_rad: (S,) first beam's direction relative to the heading.
        step_rad: (S,) angle between neighbouring beams.
        beams: (S,) beams per scanner.
        range_m: (S,).
        first: (S + 1,) where each scanner's beams start in the flat (L,) arrays.
    """

    owner: IntArray
    id: IntArray
    xy: FloatArray
    start_rad: FloatArray
    step_rad: FloatArray
    beams: IntArray
    range_m: FloatArray
    first: IntArray

    @staticmethod
    def from_specs(specs: Sequence[RobotSpec]) -> Lasers:
        """The scanners of these robots, in robot order then as each spec lists them."""
        ls = [(i, a) for i, spec in enumerate(specs) for a in spec.lasers]
        beams = np.asarray([a.beams for _, a in ls], dtype=np.int64)
        return Lasers(
            owner=np.asarray([i for i, _ in ls], dtype=np.int64),
            id=np.asarray([a.id for _, a in ls], dtype=np.int64),
            xy=np.asarray([(a.x_m, a.y_m) for _, a in ls], dtype=np.float64).reshape(-1, 2),
            start_rad=np.radians([a.start_deg for _, a in ls]).astype(np.float64),
            step_rad=np.radians([a.resolution_deg for _, a in ls]).astype(np.float64),
            beams=beams,
            range_m=np.asarray([a.range_m for _, a in ls], dtype=np.float64),
            first=np.concatenate([[0], np.cumsum(beams)]).astype(np.int64),
        )

    @cached_property
    def beam_owner(self) -> IntArray:
        """(L,) index of the robot of each beam (worked out once: the readings' noise asks each tick)."""
        return np.repeat(self.owner, self.beams)


@dataclass(frozen=True, eq=False)
class Bodies:
    """Static arrays for N robots.

    Attributes:
        ids: Robot ids, (N,).
        types: Robot types, length N.
        outline: Body outlines in each robot's frame, (N, K, 2).
        is_circle: (N,).
        radius_m: Disc radius, or 0 for rectangles, (N,).
        bound_radius_m: Radius of the smallest circle about the centre of movement holding the
            body, (N,).
        drive: Drive constants.
        ir_owner: Index of the robot each proximity sensor belongs to, (M,), sorted.
        ir_slots: (N, S) the sensor indices of each robot, padded with -1 (S the most any has).
        ir_id: Sensor ids, (M,).
        ir_xy: Mounting points in the robot frame, (M, 2).
        ir_angle_rad: Looking direction relative to the heading, (M,).
        ir_half_cone_rad: Half of each cone, (M,).
        ir_range_m: (M,).
        bumper_owner: (B,) index of the robot of each bumper.
        bumper_id: (B,).
        bumper_outline: (B, Kb, 2) bumper polygons in the robot frame (padded by repetition).
        ticks_per_m: Encoder resolution, (N,).
        lasers: The laser scanners of every robot.
        noise_mean: Noise bias per robot and sensor kind, dict of (N,) arrays.
        noise_std: Noise deviation per robot and sensor kind (0 where switched off).
    """

    ids: IntArray
    types: tuple[RobotType, ...]
    outline: FloatArray
    is_circle: BoolArray
    radius_m: FloatArray
    bound_radius_m: FloatArray
    drive: DriveParams
    ir_owner: IntArray
    ir_slots: IntArray
    ir_id: IntArray
    ir_xy: FloatArray
    ir_angle_rad: FloatArray
    ir_half_cone_rad: FloatArray
    ir_range_m: FloatArray
    bumper_owner: IntArray
    bumper_id: IntArray
    bumper_outline: FloatArray
    ticks_per_m: FloatArray
    lasers: Lasers
    noise_mean: dict[str, FloatArray]
    noise_std: dict[str, FloatArray]

    @property
    def n(self) -> int:
        """Number of robots."""
        return len(self.ids)

    @staticmethod
    def from_specs(specs: Sequence[RobotSpec]) -> Bodies:
        """Builds the arrays from accepted specs (their ``id`` fields are the robot ids).

        Args:
            specs: One spec per robot, in the order the arrays will use.

        Returns:
            The bodies.
        """
        n = len(specs)
        width = np.asarray([s.width_m for s in specs], dtype=np.float64)
        height = np.asarray([s.height_m for s in specs], dtype=np.float64)
        com = np.asarray([s.com for s in specs], dtype=np.float64)
        circle = np.asarray([s.shape == BodyShape.CIRCLE for s in specs], dtype=bool)
        outline = body_outline(width, height, com, circle) if n else np.zeros((0, 4, 2))
        ir = [(i, s) for i, spec in enumerate(specs) for s in spec.sensors]
        bumpers = [(i, b) for i, spec in enumerate(specs) for b in spec.bumpers]
        means, stds = _noise_by_kind(specs)
        return Bodies(
            ids=np.asarray([s.id for s in specs], dtype=np.int64),
            types=tuple(RobotType(s.type) for s in specs),
            outline=outline,
            is_circle=circle,
            radius_m=np.where(circle, 0.5 * width, 0.0),
            bound_radius_m=np.hypot(outline[..., 0], outline[..., 1]).max(axis=1) if n else np.zeros(0),
            drive=DriveParams(
                max_speed_mps=np.asarray([s.max_speed_mps for s in specs], dtype=np.float64),
                curve=np.asarray([s.acceleration_curve for s in specs], dtype=np.float64),
                wheel_base_m=height.copy(),
            ),
            ir_owner=np.asarray([i for i, _ in ir], dtype=np.int64),
            ir_slots=_slots([len(spec.sensors) for spec in specs]),
            ir_id=np.asarray([s.id for _, s in ir], dtype=np.int64),
            ir_xy=np.asarray([(s.x_m, s.y_m) for _, s in ir], dtype=np.float64).reshape(-1, 2),
            ir_angle_rad=np.radians([s.angle_deg for _, s in ir]).astype(np.float64),
            ir_half_cone_rad=0.5 * np.radians([s.cone_deg for _, s in ir]).astype(np.float64),
            ir_range_m=np.asarray([s.range_m for _, s in ir], dtype=np.float64),
            bumper_owner=np.asarray([i for i, _ in bumpers], dtype=np.int64),
            bumper_id=np.asarray([b.id for _, b in bumpers], dtype=np.int64),
            bumper_outline=_bumper_outlines([b for _, b in bumpers]),
            ticks_per_m=np.asarray([s.encoder.ticks_per_m for s in specs], dtype=np.float64),
            lasers=Lasers.from_specs(specs),
            noise_mean=means,
            noise_std=stds,
        )

    def world_outline(self, pose: FloatArray) -> FloatArray:
        """Body outlines in the world frame at ``pose`` (N, 3), shape (N, K, 2)."""
        return to_world(self.outline, pose[:, 0], pose[:, 1], pose[:, 2])


def _slots(counts: list[int]) -> IntArray:
    width = max(counts, default=0)
    out = np.full((len(counts), width), -1, dtype=np.int64)
    start = 0
    for i, c in enumerate(counts):
        out[i, :c] = np.arange(start, start + c)
        start += c
    return out


def polygons_at(local: FloatArray, pose: FloatArray) -> npt.NDArray[np.object_]:
    """Shapely polygons of local outlines (N, K, 2) placed at poses (N, 3)."""
    if len(local) == 0:
        return np.zeros((0,), dtype=object)
    return np.asarray(shapely.polygons(to_world(local, pose[:, 0], pose[:, 1], pose[:, 2])), dtype=object)
