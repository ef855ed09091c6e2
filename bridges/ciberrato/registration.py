"""Registration on port 6000, pure: the datagram a robot, beacon, viewer or panel registers
with, the robot a legacy registration asks for, and the server's reply (accepted, with the
simulation's parameters, or refused).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from lxml import etree

from iw_zenoh.core.params import SimParameters
from iw_zenoh.core.spec import BodyShape, IrSensorSpec, NoiseSpec, RobotSpec, RobotType, SensorNoise
from iw_zenoh.errors import ProtocolError, SpecError

from .xmlwire import digits, finish, float_attr, fmt_g, frame, onoff, parse_xml, root_is

__all__ = [
    "REGISTRATION_LIMIT",
    "Registration",
    "build_refusal",
    "build_reply",
    "legacy_noise",
    "parse_registration",
    "registration_spec",
]

REGISTRATION_LIMIT = 1023  # the legacy server reads at most this much on port 6000
LEGACY_IR_ANGLES = (0.0, 60.0, -60.0, 180.0)  # Ciber-Rato's default IR mounting angles
CIBER_RADIUS = 0.5

_REGISTRATION_ROOTS = (b"<Robot", b"<RobotBeacon", b"<View", b"<Panel")


@dataclass(frozen=True)
class Registration:
    """A registration datagram on port 6000.

    Attributes:
        kind: ``robot``, ``beacon`` (RobotBeacon), ``view`` or ``panel``.
        name: Robot name.
        robot_id: Requested id (0: first free slot; a missing or bad Id counts as 0).
        beacon_height: A RobotBeacon's height.
        ir: IR sensors as (id, angle_deg, x, y, cone_deg) with None for what was not given.
        body: Intellwheels body attributes given (width, height, com, x, y, dir, max_speed,
            acceleration_curve), by canonical name.
        type: Intellwheels Type (Simulated, Real, Door), if given.
    """

    kind: str
    name: str = ""
    robot_id: int = 0
    beacon_height: float | None = None
    ir: tuple[tuple[int, float, float | None, float | None, float | None], ...] = ()
    body: dict[str, float] = field(default_factory=dict)
    type: str | None = None


_BODY_ATTRS = {
    "width": ("Width",),
    "height": ("Height", "Heigth"),
    "com": ("COM", "COMass", "CenterOfMovement"),
    "x": ("X",),
    "y": ("Y",),
    "dir": ("DIR", "Dir"),
    "max_speed": ("MaxSpeed",),
    "acceleration_curve": ("AccelerationCurve", "AccerelationCurve"),
}


def parse_registration(datagram: bytes) -> Registration:
    """Reads a datagram sent to port 6000.

    Raises:
        ProtocolError: Over the size limit, not XML, an unknown root or child element.
    """
    text = frame(datagram, REGISTRATION_LIMIT)
    if not root_is(text, _REGISTRATION_ROOTS):
        raise ProtocolError(f"unknown registration {text[:16]!r}...; expected Robot, RobotBeacon, View or Panel")
    root = parse_xml(text)
    tag = root.tag
    if tag in ("View", "Panel"):
        if len(root):
            raise ProtocolError(f"<{tag}> takes no children")
        return Registration(kind=str(tag).lower())
    if tag not in ("Robot", "RobotBeacon"):
        raise ProtocolError(f"unknown registration <{tag}>; expected Robot, RobotBeacon, View or Panel")
    robot_id = digits(root.get("Id"), "Id")
    robot_id = 0 if robot_id is None else robot_id  # legacy: a missing or bad Id means "any"
    ir: list[tuple[int, float, float | None, float | None, float | None]] = []
    for child in root:
        if not isinstance(child.tag, str):
            continue
        if child.tag != "IRSensor":
            raise ProtocolError(f"unknown element <{child.tag}> in <{tag}>")
        sid, angle = digits(child.get("Id"), "IRSensor Id"), child.get("Angle")
        if sid is None or angle is None:
            continue  # the legacy server ignores an IRSensor without Id or Angle
        ir.append(
            (
                sid,
                float_attr(child, "Angle") or 0.0,
                float_attr(child, "X"),
                float_attr(child, "Y"),
                float_attr(child, "Cone"),
            )
        )
    body = {k: v for k, names in _BODY_ATTRS.items() if (v := float_attr(root, *names)) is not None}
    return Registration(
        kind="beacon" if tag == "RobotBeacon" else "robot",
        name=root.get("Name", ""),
        robot_id=robot_id,
        beacon_height=float_attr(root, "Height") if tag == "RobotBeacon" else None,
        ir=tuple(ir),
        body=body if tag == "Robot" else {},
        type=root.get("Type"),
    )


def legacy_noise(p: SimParameters) -> SensorNoise:
    """The sensor noise a parameters file asks for (Table 3.1 quantities, per robot)."""

    def n(std: float) -> NoiseSpec:
        return NoiseSpec(0.0, std, enabled=std > 0)

    return SensorNoise(
        proximity_m=NoiseSpec(0.0, 0.0, enabled=False),
        proximity_legacy=n(p.obstacle_noise),
        compass_deg=n(p.compass_noise),
        beacon_deg=n(p.beacon_noise),
        gps_m=n(p.gps_lin_noise),
        gps_heading_deg=n(p.gps_dir_noise),
        encoder_slip=NoiseSpec(0.0, 0.0, enabled=False),
        motion=NoiseSpec(0.0, 0.0, enabled=False),  # MotorsNoise is the world's (--motors-noise)
    )


def registration_spec(reg: Registration, params: SimParameters | None = None) -> RobotSpec:
    """The robot a legacy registration asks for.

    A plain Ciber-Rato registration (no body attributes) is a disc of diameter 1 with four IR
    sensors on its rim at the given (or default) angles; an Intellwheels one is a rectangle with
    its fields, sensors where it placed them (Table 4.5's defaults when it placed none).

    Raises:
        SpecError: A field out of range, naming it.
    """
    name = (reg.name or f"robot{reg.robot_id}")[:20]
    noise = legacy_noise(params) if params is not None else SensorNoise()
    body = reg.body
    intellwheels = bool(body) or reg.type is not None or any(s[2] is not None for s in reg.ir)
    if not intellwheels:
        angles = dict(enumerate(LEGACY_IR_ANGLES))
        for sid, angle, *_ in reg.ir:
            if sid < len(LEGACY_IR_ANGLES):
                angles[sid] = angle
        sensors = tuple(
            IrSensorSpec(
                i, CIBER_RADIUS * math.cos(math.radians(a)), CIBER_RADIUS * math.sin(math.radians(a)), a, 60.0, 1e3
            )
            for i, a in sorted(angles.items())
        )
        return RobotSpec(
            name,
            id=reg.robot_id,
            shape=BodyShape.CIRCLE,
            ir_sensors=sensors,
            legacy=True,
            noise=noise,
            beacon_height_m=(reg.beacon_height or 0.0) if reg.kind == "beacon" else None,
        )
    try:
        rtype = RobotType(reg.type) if reg.type else RobotType.SIMULATED
    except ValueError:
        raise SpecError("Type", f"must be Simulated, Real or Door, got {reg.type!r}") from None
    sensors = tuple(
        IrSensorSpec(sid, x or 0.0, y or 0.0, angle, cone if cone is not None else 60.0)
        for sid, angle, x, y, cone in reg.ir
    )
    return RobotSpec(
        name,
        id=reg.robot_id,
        type=rtype,
        width_m=body.get("width", 1.0),
        height_m=body.get("height", 1.0),
        com=body.get("com", 0.5),
        x_m=body.get("x"),
        y_m=body.get("y"),
        dir_deg=body.get("dir"),
        max_speed_mps=body.get("max_speed", 0.5),
        acceleration_curve=body.get("acceleration_curve", 0.5),
        ir_sensors=sensors,
        legacy=True,
        noise=noise,
    )


def build_reply(
    p: SimParameters, *, n_beacons: int, lab_file: str | None = None, grid_file: str | None = None
) -> bytes:
    """The ``<Reply Status="Ok">`` every robot, viewer and panel gets (at most 1024 bytes)."""
    root = etree.Element("Reply", Status="Ok")
    attrs = {
        "SimTime": str(p.sim_time),
        "CycleTime": str(p.cycle_time_ms),
        "CompassNoise": fmt_g(p.compass_noise),
        "BeaconNoise": fmt_g(p.beacon_noise),
        "ObstacleNoise": fmt_g(p.obstacle_noise),
        "MotorsNoise": fmt_g(p.motors_noise),
        "KeyTime": str(p.key_time),
        "GPS": onoff(p.gps),
        "GPSLinNoise": fmt_g(p.gps_lin_noise),
        "GPSDirNoise": fmt_g(p.gps_dir_noise),
        "BeaconSensor": onoff(p.beacon_sensor),
        "CompassSensor": onoff(p.compass_sensor),
        "ScoreSensor": onoff(p.score_sensor),
        "ShowActions": "True" if p.show_actions else "False",
        "NBeacons": str(n_beacons),
        "NRequestsPerCycle": str(p.n_requests_per_cycle),
        "ObstacleRequestable": onoff(p.obstacle_requestable),
        "BeaconRequestable": onoff(p.beacon_requestable),
        "GroundRequestable": onoff(p.ground_requestable),
        "CompassRequestable": onoff(p.compass_requestable),
        "CollisionRequestable": onoff(p.collision_requestable),
        "ObstacleLatency": str(p.obstacle_latency),
        "BeaconLatency": str(p.beacon_latency),
        "GroundLatency": str(p.ground_latency),
        "CompassLatency": str(p.compass_latency),
        "CollisionLatency": str(p.collision_latency),
        "BeaconAperture": f"{p.beacon_aperture_rad:f}",
        "ReturnTimePenalty": str(p.return_time_penalty),
        "ArrivalTimePenalty": str(p.arrival_time_penalty),
        "CollisionWallPenalty": str(p.collision_wall_penalty),
        "CollisionRobotPenalty": str(p.collision_robot_penalty),
        "TargetReward": str(p.target_reward),
        "HomeReward": str(p.home_reward),
    }
    params = etree.SubElement(root, "Parameters")
    for k, v in attrs.items():
        params.set(k, v)
    for k, path in (("Lab", lab_file), ("Grid", grid_file)):
        if path is not None:
            params.set(k, path)
    data = finish(root)
    if len(data) > 1024 and (lab_file or grid_file):
        return build_reply(p, n_beacons=n_beacons)  # long file names would not fit the clients' 1024 bytes
    return data


def build_refusal() -> bytes:
    """``<Reply Status="Refused"></Reply>`` and its terminator."""
    root = etree.Element("Reply", Status="Refused")
    root.text = ""
    return bytes(etree.tostring(root, encoding="utf-8")) + b"\n\x00"
