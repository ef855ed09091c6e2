"""Robot registration specs: every field of the seed's Tables 4.3-4.5 and of Ciber-Rato, with
their defaults and ranges.

A value out of range raises :class:`~iw_zenoh.errors.SpecError` naming the field and the reason;
nothing is clamped silently.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field, replace

from iw_zenoh.errors import SpecError

__all__ = [
    "LEGACY_MAX_IR",
    "MAX_BODY_M",
    "MAX_BUMPERS",
    "MAX_BUMPER_CORNERS",
    "MAX_IR",
    "MAX_LASERS",
    "MAX_SPEED_MPS",
    "NAME_MAX_CHARS",
    "BodyShape",
    "BumperSpec",
    "EncoderSpec",
    "IrSensorSpec",
    "LaserSpec",
    "NoiseSpec",
    "RobotSpec",
    "RobotType",
    "SensorNoise",
    "check_counts",
    "default_ir_sensors",
    "prototype_chair",
    "prototype_sensors",
]

NAME_MAX_CHARS = 20  # Table 4.3
LEGACY_MAX_IR = 8  # Intellwheels registers at most 8 proximity sensors (ids 0..7)
DEFAULT_IR_RANGE_M = 4.0  # choice: a sonar's useful range; the seed gives none
LASER_MAX_BEAMS = 4096  # a 0.1-degree scanner over 360 degrees is 3,600 beams
LASER_MAX_RANGE_M = 100.0  # beyond any indoor scanner's (and any lab's diagonal here)
MAX_SPEED_MPS = 100.0  # far past any wheelchair's; a faster one's poses overflow to beyond the wire's limits
# one registration must not make every tick's cost (and memory) huge; the seed bounds only the
# legacy sensors (8), so these are choices, generous for any chair, door or Ciber-Rato robot:
MAX_IR = 64  # proximity sensors of a native robot (a ring of sonars every 6 degrees is 60)
MAX_LASERS = 8  # laser scanners, each of at most LASER_MAX_BEAMS beams
MAX_BUMPERS = 16  # contact sensors ...
MAX_BUMPER_CORNERS = 64  # ... each a polygon of at most this many corners
MAX_BODY_M = 10.0  # width and height: a bed, a revolving door's wings, a car are under it


class RobotType(enum.StrEnum):
    """Who moves a robot: the world (Simulated, Door) or its own odometry (Real)."""

    SIMULATED = "Simulated"
    REAL = "Real"
    DOOR = "Door"


class BodyShape(enum.StrEnum):
    """Rectangle (Intellwheels) or disc (Ciber-Rato)."""

    RECT = "rect"
    CIRCLE = "circle"


def _finite(name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SpecError(name, f"must be a number, got {value!r}")
    if not math.isfinite(value):
        raise SpecError(name, f"must be a finite number, got {value!r}")
    return float(value)


def _positive(name: str, value: float) -> None:
    if _finite(name, value) <= 0.0:
        raise SpecError(name, f"must be > 0, got {value!r}")


def _within(name: str, value: float, lo: float, hi: float, *, lo_open: bool, hi_open: bool) -> None:
    v = _finite(name, value)
    bad_lo = v <= lo if lo_open else v < lo
    bad_hi = v >= hi if hi_open else v > hi
    if bad_lo or bad_hi:
        left = "]" if lo_open else "["
        right = "[" if hi_open else "]"
        raise SpecError(name, f"must be in {left}{lo:g};{hi:g}{right}, got {value!r}")


@dataclass(frozen=True)
class NoiseSpec:
    """Additive Gaussian noise on one sensor: ``value + N(mean, std)`` when enabled.

    Attributes:
        mean: Bias, in the sensor's unit.
        std: Standard deviation, in the sensor's unit, >= 0.
        enabled: When false the sensor reads the true value.
    """

    mean: float = 0.0
    std: float = 0.0
    enabled: bool = True

    def __post_init__(self) -> None:
        _finite("noise.mean", self.mean)
        if _finite("noise.std", self.std) < 0.0:
            raise SpecError("noise.std", f"must be >= 0, got {self.std!r}")


@dataclass(frozen=True)
class SensorNoise:
    """Noise of every sensor of one robot. Defaults follow Ciber-Rato's Table 3.1.

    Attributes:
        proximity_m: On proximity distances, metres.
        proximity_legacy: On the legacy 1/d reading (Ciber-Rato ObstacleNoise).
        compass_deg: On the compass heading.
        beacon_deg: On beacon bearings.
        gps_m: On GPS x and y.
        gps_heading_deg: On the GPS heading.
        encoder_slip: Relative wheel slip per tick (a fraction of the distance the wheel rolled).
        motion: Relative noise on each wheel's speed (movement noise, off by default).
        laser_m: On each laser beam's range, metres (a typical 2D scanner's 1 cm).
    """

    proximity_m: NoiseSpec = NoiseSpec(0.0, 0.01)
    proximity_legacy: NoiseSpec = NoiseSpec(0.0, 0.1)
    compass_deg: NoiseSpec = NoiseSpec(0.0, 2.0)
    beacon_deg: NoiseSpec = NoiseSpec(0.0, 2.0)
    gps_m: NoiseSpec = NoiseSpec(0.0, 0.5)
    gps_heading_deg: NoiseSpec = NoiseSpec(0.0, 5.0)
    encoder_slip: NoiseSpec = NoiseSpec(0.0, 0.02)
    motion: NoiseSpec = NoiseSpec(0.0, 0.0, enabled=False)
    laser_m: NoiseSpec = NoiseSpec(0.0, 0.01)

    @staticmethod
    def off() -> SensorNoise:
        """Every sensor exact and no movement noise."""
        z = NoiseSpec(0.0, 0.0, enabled=False)
        return SensorNoise(z, z, z, z, z, z, z, z, z)


@dataclass(frozen=True)
class IrSensorSpec:
    """A proximity sensor (sonar or infrared) on a robot, Table 4.4.

    Attributes:
        id: Sensor id (0..7 for legacy registrations; any non-negative id natively).
        x_m: Mounting x relative to the centre of movement, along the heading.
        y_m: Mounting y relative to the centre of movement, to the left.
        angle_deg: Looking direction relative to the heading, in [-180, 180].
        cone_deg: Full opening angle, in ]0, 180[ (50-70 a sonar, 1-10 an IR sensor).
        range_m: Farthest distance it reports; beyond it reads "nothing".
    """

    id: int
    x_m: float = 0.0
    y_m: float = 0.0
    angle_deg: float = 0.0
    cone_deg: float = 60.0
    range_m: float = DEFAULT_IR_RANGE_M

    def __post_init__(self) -> None:
        if isinstance(self.id, bool) or not isinstance(self.id, int) or self.id < 0:
            raise SpecError("ir.id", f"must be an integer >= 0, got {self.id!r}")
        p = f"ir[{self.id}]"
        _finite(f"{p}.x_m", self.x_m)
        _finite(f"{p}.y_m", self.y_m)
        _within(f"{p}.angle", self.angle_deg, -180.0, 180.0, lo_open=False, hi_open=False)
        _within(f"{p}.cone", self.cone_deg, 0.0, 180.0, lo_open=True, hi_open=True)
        _positive(f"{p}.range", self.range_m)


@dataclass(frozen=True)
class LaserSpec:
    """A 2D laser range finder (a scanning lidar) on a robot: ``beams`` rays spread evenly over
    ``fov_deg``, centred on ``angle_deg``, each reading the distance to the first wall, obstacle,
    door or other body it meets within ``range_m``.

    Attributes:
        id: Scanner id, unique on the robot.
        x_m: Mounting x relative to the centre of movement, along the heading.
        y_m: Mounting y relative to the centre of movement, to the left.
        angle_deg: Direction of the middle of the field of view relative to the heading, in
            [-180, 180].
        fov_deg: Field of view, in ]0, 360]; the first beam looks ``angle - fov/2``, the last
            ``angle + fov/2`` (at 360 the first and last beams look the same way).
        beams: Number of beams, 1 to 4,096 (one beam looks along ``angle_deg``).
        range_m: Farthest distance a beam reports, in ]0, 100].
    """

    id: int
    x_m: float = 0.0
    y_m: float = 0.0
    angle_deg: float = 0.0
    fov_deg: float = 270.0
    beams: int = 64
    range_m: float = 10.0

    def __post_init__(self) -> None:
        if isinstance(self.id, bool) or not isinstance(self.id, int) or self.id < 0:
            raise SpecError("laser.id", f"must be an integer >= 0, got {self.id!r}")
        p = f"laser[{self.id}]"
        _finite(f"{p}.x_m", self.x_m)
        _finite(f"{p}.y_m", self.y_m)
        _within(f"{p}.angle", self.angle_deg, -180.0, 180.0, lo_open=False, hi_open=False)
        _within(f"{p}.fov", self.fov_deg, 0.0, 360.0, lo_open=True, hi_open=False)
        if isinstance(self.beams, bool) or not isinstance(self.beams, int) or not 1 <= self.beams <= LASER_MAX_BEAMS:
            raise SpecError(f"{p}.beams", f"must be an integer in [1;{LASER_MAX_BEAMS}], got {self.beams!r}")
        _within(f"{p}.range", self.range_m, 0.0, LASER_MAX_RANGE_M, lo_open=True, hi_open=False)

    @property
    def resolution_deg(self) -> float:
        """Angle between neighbouring beams (0 for a single beam)."""
        return self.fov_deg / (self.beams - 1) if self.beams > 1 else 0.0

    @property
    def start_deg(self) -> float:
        """Direction of the first beam relative to the heading."""
        return self.angle_deg - 0.5 * self.fov_deg if self.beams > 1 else self.angle_deg


@dataclass(frozen=True)
class BumperSpec:
    """A contact sensor: a polygon in the robot frame that reads yes when it touches anything.

    Attributes:
        id: Bumper id.
        corners: Polygon vertices in the robot frame (metres), at least 3.
    """

    id: int
    corners: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        if len(self.corners) < 3:
            raise SpecError(f"bumper[{self.id}].corners", f"needs at least 3 corners, got {len(self.corners)}")
        if len(self.corners) > MAX_BUMPER_CORNERS:
            raise SpecError(f"bumper[{self.id}].corners", f"at most {MAX_BUMPER_CORNERS}, got {len(self.corners)}")
        for i, (cx, cy) in enumerate(self.corners):
            _finite(f"bumper[{self.id}].corners[{i}].x", cx)
            _finite(f"bumper[{self.id}].corners[{i}].y", cy)


@dataclass(frozen=True)
class EncoderSpec:
    """Wheel encoders.

    Attributes:
        ticks_per_m: Encoder ticks per metre a wheel rolls.
    """

    ticks_per_m: float = 2000.0

    def __post_init__(self) -> None:
        _positive("encoder.ticks_per_m", self.ticks_per_m)


def _bounded(spec: RobotSpec) -> None:
    """Refuses a body over :data:`MAX_BODY_M` and more sensors than :func:`check_counts` takes."""
    for name, m in (("width_m", spec.width_m), ("height_m", spec.height_m)):
        if m > MAX_BODY_M:
            raise SpecError(name, f"must be at most {MAX_BODY_M:g} m, got {m!r}")
    check_counts(len(spec.ir_sensors), len(spec.lasers), len(spec.bumpers))


def check_counts(ir_sensors: int, lasers: int, bumpers: int) -> None:
    """Refuses more sensors than :data:`MAX_IR`, :data:`MAX_LASERS` or :data:`MAX_BUMPERS`
    (checked before a registration's sensors are built, and again by :class:`RobotSpec`).

    Raises:
        SpecError: Naming the field, its limit and the count.
    """
    for name, n, most in (
        ("ir_sensors", ir_sensors, MAX_IR),
        ("lasers", lasers, MAX_LASERS),
        ("bumpers", bumpers, MAX_BUMPERS),
    ):
        if n > most:
            raise SpecError(name, f"at most {most} per robot, got {n} (every tick computes each one)")


PROTOTYPE_SENSOR_LAYOUT = (
    (0.72, 0.24, 0.0),
    (0.72, -0.24, 0.0),
    (0.54, 0.24, 90.0),
    (0.54, -0.24, -90.0),
    (0.05, 0.28, 90.0),
    (0.05, -0.28, -90.0),
    (-0.03, 0.28, 180.0),
    (-0.03, -0.28, 180.0),
)  # (x, y, angle) of the LIACC prototype's eight sonars, section 5.4.4


def prototype_sensors(range_m: float = DEFAULT_IR_RANGE_M) -> tuple[IrSensorSpec, ...]:
    """The LIACC prototype chair's eight 60-degree sonars (section 5.4.4)."""
    return tuple(IrSensorSpec(i, x, y, a, 60.0, range_m) for i, (x, y, a) in enumerate(PROTOTYPE_SENSOR_LAYOUT))


def prototype_chair(name: str, *, range_m: float = DEFAULT_IR_RANGE_M, **overrides: object) -> RobotSpec:
    """The prototype chair measured at LIACC: Width 1.04, Height 0.66, COM 0.81, MaxSpeed 0.5,
    AccelerationCurve 0.2, eight sonars; ``overrides`` replace any field."""
    args: dict[str, object] = {
        "width_m": 1.04,
        "height_m": 0.66,
        "com": 0.81,
        "max_speed_mps": 0.5,
        "acceleration_curve": 0.2,
        "ir_sensors": prototype_sensors(range_m),
    }
    args.update(overrides)
    return RobotSpec(name, **args)  # type: ignore[arg-type]


def default_ir_sensors(width_m: float, height_m: float, com: float) -> tuple[IrSensorSpec, ...]:
    """The four sensors the seed places when none are registered (Table 4.5).

    Args:
        width_m: Body length along the heading.
        height_m: Body size across the heading.
        com: Centre of movement fraction.

    Returns:
        Sensors 0 (front), 1 (left), 2 (right), 3 (back), cone 60 degrees each.
    """
    return (
        IrSensorSpec(0, width_m * com, 0.0, 0.0, 60.0),
        IrSensorSpec(1, 0.0, 0.5 * height_m, 90.0, 60.0),
        IrSensorSpec(2, 0.0, -0.5 * height_m, -90.0, 60.0),
        IrSensorSpec(3, -width_m * (1.0 - com), 0.0, 180.0, 60.0),
    )


@dataclass(frozen=True)
class RobotSpec:
    """A robot registration, Table 4.3 plus the native extensions.

    Attributes:
        name: Up to 20 characters.
        id: Requested id; 0 asks the world for the first free grid slot.
        type: Simulated, Real or Door.
        shape: Rectangle or disc (Ciber-Rato's is 1 across); a disc's width and height are its
            diameter.
        width_m: Length along the heading, in ]0;10] m (MAX_BODY_M).
        height_m: Size across the heading and wheel base, in ]0;10] m.
        com: Centre of movement as a fraction of width from the rear, in ]0;1[.
        x_m: Start x (> 0), or ``None`` for the grid position.
        y_m: Start y (> 0), or ``None`` for the grid position.
        dir_deg: Start heading in [-180;180], or ``None`` for the grid's.
        max_speed_mps: Top speed at power 0.15 on both wheels, in ]0;100] m/s.
        acceleration_curve: Motor inertia, in ]0;1].
        ir_sensors: Proximity sensors (at most 64; 8 when legacy); empty means the four defaults of Table 4.5.
        bumpers: Contact sensors (at most 16, of 3 to 64 corners).
        lasers: 2D laser range finders (none by default; at most 8).
        encoder: Wheel encoder parameters.
        noise: Sensor and movement noise.
        legacy: A Ciber-Rato / Intellwheels registration: at most 8 sensors with ids 0..7.
        beacon_height_m: The robot carries a beacon of this height (Ciber-Rato's RobotBeacon):
            other robots' beacon sensors point at it as it moves. ``None``: no beacon.
    """

    name: str
    id: int = 0
    type: RobotType = RobotType.SIMULATED
    shape: BodyShape = BodyShape.RECT
    width_m: float = 1.0
    height_m: float = 1.0
    com: float = 0.5
    x_m: float | None = None
    y_m: float | None = None
    dir_deg: float | None = None
    max_speed_mps: float = 0.5
    acceleration_curve: float = 0.5
    ir_sensors: tuple[IrSensorSpec, ...] = ()
    bumpers: tuple[BumperSpec, ...] = ()
    lasers: tuple[LaserSpec, ...] = ()
    encoder: EncoderSpec = field(default_factory=EncoderSpec)
    noise: SensorNoise = field(default_factory=SensorNoise)
    legacy: bool = False
    beacon_height_m: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise SpecError("name", "is required: a non-empty string")
        if len(self.name) > NAME_MAX_CHARS:
            raise SpecError("name", f"must be at most {NAME_MAX_CHARS} characters, got {len(self.name)}")
        if any(ord(c) < 32 for c in self.name):
            raise SpecError("name", "must not contain control characters")
        if isinstance(self.id, bool) or not isinstance(self.id, int) or self.id < 0:
            raise SpecError("id", f"must be an integer >= 0 (0 = first free grid slot), got {self.id!r}")
        try:
            RobotType(self.type)
        except ValueError:
            raise SpecError("type", f"must be Simulated, Real or Door, got {self.type!r}") from None
        try:
            BodyShape(self.shape)
        except ValueError:
            raise SpecError("shape", f"must be rect or circle, got {self.shape!r}") from None
        _positive("width_m", self.width_m)
        _positive("height_m", self.height_m)
        _bounded(self)
        _within("com", self.com, 0.0, 1.0, lo_open=True, hi_open=True)
        for name, v in (("x_m", self.x_m), ("y_m", self.y_m)):
            if v is not None:
                _positive(name, v)
        if self.dir_deg is not None:
            _within("dir_deg", self.dir_deg, -180.0, 180.0, lo_open=False, hi_open=False)
        _within("max_speed_mps", self.max_speed_mps, 0.0, MAX_SPEED_MPS, lo_open=True, hi_open=False)
        _within("acceleration_curve", self.acceleration_curve, 0.0, 1.0, lo_open=True, hi_open=False)
        ids = [s.id for s in self.ir_sensors]
        if len(set(ids)) != len(ids):
            raise SpecError("ir_sensors", f"sensor ids must be unique, got {ids}")
        if self.legacy:
            if len(self.ir_sensors) > LEGACY_MAX_IR:
                raise SpecError(
                    "ir_sensors", f"a legacy robot has at most {LEGACY_MAX_IR} sensors, got {len(self.ir_sensors)}"
                )
            bad = [i for i in ids if i >= LEGACY_MAX_IR]
            if bad:
                raise SpecError("ir_sensors", f"legacy sensor ids are 0..{LEGACY_MAX_IR - 1}, got {bad}")
        if self.shape == BodyShape.CIRCLE and self.width_m != self.height_m:
            raise SpecError(
                "height_m",
                f"a circle's width and height are its diameter and must match, "
                f"got {self.width_m!r} and {self.height_m!r}",
            )
        if self.beacon_height_m is not None:
            _within("beacon_height_m", self.beacon_height_m, 0.0, 1e3, lo_open=False, hi_open=False)
        if len({b.id for b in self.bumpers}) != len(self.bumpers):
            raise SpecError("bumpers", "bumper ids must be unique")
        if len({s.id for s in self.lasers}) != len(self.lasers):
            raise SpecError("lasers", f"laser ids must be unique, got {[s.id for s in self.lasers]}")

    @property
    def sensors(self) -> tuple[IrSensorSpec, ...]:
        """The proximity sensors in use: the registered ones, or Table 4.5's four defaults."""
        return self.ir_sensors or default_ir_sensors(self.width_m, self.height_m, self.com)

    @property
    def wheel_base_m(self) -> float:
        """Distance between the wheels: the body's height (across the heading)."""
        return self.height_m

    def placed(self, robot_id: int, x_m: float, y_m: float, dir_deg: float) -> RobotSpec:
        """A copy with its id and start pose set (what the world answers a registration with)."""
        return replace(self, id=robot_id, x_m=x_m, y_m=y_m, dir_deg=dir_deg)
