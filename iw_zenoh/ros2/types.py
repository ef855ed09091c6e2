"""The ROS 2 message types iw-zenoh speaks, their names on rmw_zenoh's keys, their type hashes and
their CDR payloads: all from rosbags' ROS 2 Jazzy type store (an implementation of ROS 2's own
message definitions, CDR and REP-2011 hashing that we did not write), nothing typed in by hand.

* ``dds_name("nav_msgs/msg/Odometry")`` is ``nav_msgs::msg::dds_::Odometry_`` (the DDS type name
  rmw_zenoh puts in keys and tokens);
* ``type_hash(...)`` is the ``RIHS01_<sha256>`` ROS 2 Jazzy computes from the type description;
* :func:`serialize` and :func:`deserialize` write and read the CDR payload (little-endian
  encapsulation ``00 01 00 00``); a payload that does not decode is a :class:`DecodeError` with
  the reason, never a half-read message.
"""

from __future__ import annotations

import functools
from typing import Any

from rosbags.typesys import Stores, get_typestore

from iw_zenoh.errors import DecodeError

__all__ = [
    "CLOCK",
    "JOY",
    "LASER_SCAN",
    "MAX_PAYLOAD",
    "ODOMETRY",
    "RANGE",
    "TF_MESSAGE",
    "TWIST",
    "TWIST_STAMPED",
    "TYPES",
    "dds_name",
    "deserialize",
    "msgdef",
    "serialize",
    "store",
    "type_hash",
]

ODOMETRY = "nav_msgs/msg/Odometry"
LASER_SCAN = "sensor_msgs/msg/LaserScan"
RANGE = "sensor_msgs/msg/Range"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
CLOCK = "rosgraph_msgs/msg/Clock"
TWIST = "geometry_msgs/msg/Twist"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
TYPES = (ODOMETRY, LASER_SCAN, RANGE, TF_MESSAGE, CLOCK, TWIST, TWIST_STAMPED)  # on the live bus (golden hashes)
JOY = "sensor_msgs/msg/Joy"  # a driver's recorded inputs, in exported bags only (iwz export --ros2)
# the largest command taken from the bus: a TwistStamped with a frame name of a few hundred
# characters is under 1 KiB; anything far larger is refused before it is parsed
MAX_PAYLOAD = 4096
_CDR_LE = b"\x00\x01\x00\x00"


@functools.cache
def store() -> Any:
    """The ROS 2 Jazzy type store of rosbags (built once)."""
    return get_typestore(Stores.ROS2_JAZZY)


def _known(name: str) -> str:
    if name not in store().types:
        raise ValueError(f"unknown ROS 2 type {name!r}: expected a name like 'nav_msgs/msg/Odometry'")
    return name


def dds_name(name: str) -> str:
    """The DDS type name rmw_zenoh uses: ``pkg/msg/Name`` -> ``pkg::msg::dds_::Name_``."""
    pkg, kind, base = _known(name).split("/")
    return f"{pkg}::{kind}::dds_::{base}_"


@functools.cache
def type_hash(name: str) -> str:
    """The type's REP-2011 hash, ``RIHS01_`` and 64 hex digits, computed from its description."""
    return str(store().hash_rihs01(_known(name)))


@functools.cache
def msgdef(name: str) -> str:
    """The type's ``ros2msg`` schema text (the message and every type it uses), for rosbag2."""
    return str(store().generate_msgdef(_known(name), ros_version=2)[0])


def new(name: str, **fields: Any) -> Any:
    """A message object of the type (rosbags' class), from its fields."""
    return store().types[_known(name)](**fields)


def serialize(msg: Any) -> bytes:
    """The CDR payload (little-endian, with its encapsulation header) of a message object."""
    return bytes(store().serialize_cdr(msg, msg.__msgtype__))


def deserialize(data: bytes, name: str) -> Any:
    """Reads a CDR payload of a known type.

    Raises:
        DecodeError: The payload is too large, not little- or big-endian plain CDR, truncated, or
            holds a length past its end (what rosbags refuses), with the reason.
    """
    if len(data) > MAX_PAYLOAD:
        raise DecodeError(f"a {name} payload of {len(data)} bytes is refused (at most {MAX_PAYLOAD})")
    if len(data) < 4 or data[:1] != b"\x00" or data[1:2] not in (b"\x00", b"\x01"):
        raise DecodeError(f"not a plain CDR {name}: the encapsulation header is {bytes(data[:4]).hex() or 'missing'}")
    try:
        return store().deserialize_cdr(bytes(data), _known(name))
    except Exception as e:  # rosbags' SerdeError and whatever a hostile length makes it meet
        raise DecodeError(f"{name} does not decode: {e}") from None


def header_le() -> bytes:
    """The encapsulation header every payload iw-zenoh writes starts with (CDR, little-endian)."""
    return _CDR_LE
