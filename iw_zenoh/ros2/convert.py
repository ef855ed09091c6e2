"""Our world's state and readings as ROS 2 messages (CDR payloads), and ROS 2 velocity commands
back: pure functions of plain values, no bus.

Frames follow REP 105 with each chair's namespace as a prefix (``/robot1`` -> ``robot1/odom``,
``robot1/base_link``, ``robot1/laser0``, ``robot1/range0``); times are the simulation's
(``/clock``), so a ROS 2 stack runs with ``use_sim_time``. A beam or cone that sees nothing
within its range reads ``+inf`` (REP 117).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from iw_zenoh.errors import DecodeError
from iw_zenoh.ros2 import types as t

__all__ = [
    "Frames",
    "Pose2",
    "clock",
    "laser_scan",
    "odometry",
    "range_reading",
    "stamp",
    "tf_message",
    "twist_of",
]

ULTRASOUND = 0  # sensor_msgs/Range radiation_type: our cones are sonars


@dataclass(frozen=True)
class Frames:
    """A chair's frame names under its namespace (``/robot1`` -> ``robot1/odom``...)."""

    prefix: str

    @classmethod
    def of(cls, namespace: str) -> Frames:
        """The frames of a chair in ``namespace`` (its slashes dropped: frame ids have none first)."""
        return cls(namespace.strip("/"))

    def name(self, frame: str) -> str:
        """``frame`` under the chair's prefix (``laser1`` -> ``robot1/laser1``)."""
        return f"{self.prefix}/{frame}" if self.prefix else frame

    @property
    def odom(self) -> str:
        """The chair's odometry frame, fixed in the world."""
        return self.name("odom")

    @property
    def base(self) -> str:
        """The chair's body frame."""
        return self.name("base_link")


@dataclass(frozen=True)
class Pose2:
    """A planar pose (m, m, rad) and its body-frame velocity (m/s, rad/s)."""

    x: float
    y: float
    heading: float
    v: float = 0.0
    w: float = 0.0


def stamp(sim_time_ns: int) -> object:
    """builtin_interfaces/Time of a simulation time."""
    sec, nanosec = divmod(int(sim_time_ns), 1_000_000_000)
    return t.new("builtin_interfaces/msg/Time", sec=sec, nanosec=nanosec)


def _header(sim_time_ns: int, frame: str) -> object:
    return t.new("std_msgs/msg/Header", stamp=stamp(sim_time_ns), frame_id=frame)


def _quat(heading: float) -> object:
    return t.new("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=math.sin(heading / 2), w=math.cos(heading / 2))


def _vec(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> object:
    return t.new("geometry_msgs/msg/Vector3", x=float(x), y=float(y), z=float(z))


def odometry(frames: Frames, sim_time_ns: int, p: Pose2) -> bytes:
    """nav_msgs/Odometry: the pose in ``odom`` (the world's frame), the velocity in ``base_link``."""
    zeros = np.zeros(36, dtype=np.float64)
    pose = t.new(
        "geometry_msgs/msg/Pose",
        position=t.new("geometry_msgs/msg/Point", x=p.x, y=p.y, z=0.0),
        orientation=_quat(p.heading),
    )
    twist = t.new("geometry_msgs/msg/Twist", linear=_vec(p.v), angular=_vec(z=p.w))
    return t.serialize(
        t.new(
            t.ODOMETRY,
            header=_header(sim_time_ns, frames.odom),
            child_frame_id=frames.base,
            pose=t.new("geometry_msgs/msg/PoseWithCovariance", pose=pose, covariance=zeros),
            twist=t.new("geometry_msgs/msg/TwistWithCovariance", twist=twist, covariance=zeros),
        )
    )


def laser_scan(
    frame: str,
    sim_time_ns: int,
    *,
    angle_deg: float,
    fov_deg: float,
    range_m: float,
    ranges: Sequence[float | None],
    scan_time_s: float,
) -> bytes:
    """sensor_msgs/LaserScan of one scanner's sweep (first beam at ``angle - fov/2``)."""
    n = len(ranges)
    half = math.radians(fov_deg) / 2
    centre = math.radians(angle_deg)
    r = np.array([math.inf if v is None else v for v in ranges], dtype=np.float32)
    return t.serialize(
        t.new(
            t.LASER_SCAN,
            header=_header(sim_time_ns, frame),
            angle_min=centre - half if n > 1 else centre,
            angle_max=centre + half if n > 1 else centre,
            angle_increment=2 * half / (n - 1) if n > 1 else 0.0,
            time_increment=0.0,
            scan_time=float(scan_time_s),
            range_min=0.0,
            range_max=float(range_m),
            ranges=r,
            intensities=np.zeros(0, dtype=np.float32),
        )
    )


def range_reading(frame: str, sim_time_ns: int, *, cone_deg: float, range_m: float, value: float | None) -> bytes:
    """sensor_msgs/Range of one proximity cone (``+inf``: nothing within range)."""
    return t.serialize(
        t.new(
            t.RANGE,
            header=_header(sim_time_ns, frame),
            radiation_type=ULTRASOUND,
            field_of_view=math.radians(cone_deg),
            min_range=0.0,
            max_range=float(range_m),
            range=math.inf if value is None else float(value),
            variance=0.0,
        )
    )


@functools.lru_cache(maxsize=4096)
def _tf_body(x: float, y: float, heading: float) -> object:
    """A planar transform (the sensors' mountings repeat every tick: built once)."""
    return t.new("geometry_msgs/msg/Transform", translation=_vec(x, y), rotation=_quat(heading))


def tf_message(sim_time_ns: int, links: Sequence[tuple[str, str, float, float, float]]) -> bytes:
    """tf2_msgs/TFMessage of ``(parent, child, x, y, heading)`` links (odom -> base_link of each
    chair, base_link -> each sensor); links of one parent share its header."""
    when = stamp(sim_time_ns)
    headers: dict[str, object] = {}
    out = []
    for parent, child, x, y, heading in links:
        header = headers.get(parent)
        if header is None:
            header = headers[parent] = t.new("std_msgs/msg/Header", stamp=when, frame_id=parent)
        body = _tf_body(float(x), float(y), float(heading))
        out.append(t.new("geometry_msgs/msg/TransformStamped", header=header, child_frame_id=child, transform=body))
    return t.serialize(t.new(t.TF_MESSAGE, transforms=out))


def clock(sim_time_ns: int) -> bytes:
    """rosgraph_msgs/Clock of a simulation time."""
    return t.serialize(t.new(t.CLOCK, clock=stamp(sim_time_ns)))


def joy(sim_time_ns: int, frame: str, *, x: float, y: float, buttons: int, bits: int = 16) -> bytes:
    """sensor_msgs/Joy of a driver's input: ``axes`` ``[-x, y]`` (ROS's stick convention: axis 0
    positive to the left, axis 1 positive forward; ``x`` is our stick's rightward), ``buttons``
    the ``bits`` low bits of ``buttons``, bit 0 (the dead-man) first."""
    return t.serialize(
        t.new(
            t.JOY,
            header=_header(sim_time_ns, frame),
            axes=np.array([-float(x), float(y)], dtype=np.float32),
            buttons=np.array([(buttons >> b) & 1 for b in range(bits)], dtype=np.int32),
        )
    )


def twist(v: float, w: float, *, stamped: bool = False, sim_time_ns: int = 0, frame: str = "") -> bytes:
    """A velocity command's CDR (Twist, or TwistStamped): what a ROS 2 stack sends on cmd_vel."""
    tw = t.new(t.TWIST, linear=_vec(v), angular=_vec(z=w))
    msg = t.new(t.TWIST_STAMPED, header=_header(sim_time_ns, frame), twist=tw) if stamped else tw
    return t.serialize(msg)


def twist_of(data: bytes, *, stamped: bool = False) -> tuple[float, float]:
    """``(v, w)`` (m/s forward, rad/s counter-clockwise) of a cmd_vel payload.

    Raises:
        DecodeError: Not a Twist (TwistStamped) CDR payload, or a value that is not finite.
    """
    msg = t.deserialize(data, t.TWIST_STAMPED if stamped else t.TWIST)
    tw = msg.twist if stamped else msg
    values = (tw.linear.x, tw.linear.y, tw.linear.z, tw.angular.x, tw.angular.y, tw.angular.z)
    if not all(math.isfinite(v) for v in values):
        raise DecodeError(f"a cmd_vel with a value that is not finite is refused: {values}")
    return float(tw.linear.x), float(tw.angular.z)
