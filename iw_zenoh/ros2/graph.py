"""rmw_zenoh's (ROS 2 Jazzy) graph conventions as plain strings and bytes: the names inside a
liveliness token, the compact QoS string, and the attachment every published sample carries.

Read from rmw_zenoh's ``liveliness_utils.cpp`` and ``attachment_helpers.cpp`` (Jazzy, 0.2.4 on):

* a token is ``@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/<node>``
  and, for a publisher or subscription, ``/<topic>/<DDS type>/<type hash>/<qos>``; every ``/``
  inside a name becomes ``%`` (the root namespace and enclave ``/`` become ``%``);
* the QoS string is ``reliability:durability:history,depth:deadline s,ns:lifespan s,ns:liveliness,
  lease s,lease ns``, each field left empty when it is rmw_zenoh's default (reliable, volatile,
  keep last, infinite durations, automatic liveliness) and written as rmw's enum number otherwise;
* the attachment is Zenoh's own serialization of the sequence number (int64), the source
  timestamp (int64, ns) and the publisher's GID (a 16-byte sequence: its length, then the bytes).
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass

from iw_zenoh.errors import DecodeError

__all__ = [
    "Attachment",
    "Qos",
    "entity_parts",
    "gid_of",
    "mangle",
    "node_parts",
]

NODE, PUBLISHER, SUBSCRIPTION = "NN", "MP", "MS"
GID_BYTES = 16
RELIABLE, BEST_EFFORT = 1, 2  # rmw_qos_reliability_policy_e
TRANSIENT_LOCAL, VOLATILE = 1, 2  # rmw_qos_durability_policy_e
KEEP_LAST, KEEP_ALL = 1, 2  # rmw_qos_history_policy_e
DEFAULT_DEPTH = 42  # rmw_zenoh's default history depth: a depth of 42 is left out of the string
_DEFAULTS = (RELIABLE, VOLATILE, KEEP_LAST)


@dataclass(frozen=True)
class Qos:
    """The QoS of a publisher or subscription, as far as iw-zenoh sets it (durations infinite,
    liveliness automatic)."""

    depth: int = 10
    reliability: int = RELIABLE
    durability: int = VOLATILE
    history: int = KEEP_LAST

    def key(self) -> str:
        """rmw_zenoh's compact string of this profile (``::,10:,:,:,,`` for reliable, volatile,
        keep last 10)."""
        own = (self.reliability, self.durability, self.history)
        rel, dur, hist = ("" if v == d else str(v) for v, d in zip(own, _DEFAULTS, strict=True))
        depth = "" if self.depth == DEFAULT_DEPTH else str(self.depth)
        return f"{rel}:{dur}:{hist},{depth}:,:,:,,"


def mangle(name: str) -> str:
    """A name as a single token chunk: every ``/`` becomes ``%`` (``/robot1/odom`` -> ``%robot1%odom``)."""
    return name.replace("/", "%")


def node_parts(zid: str, node_id: int, namespace: str, node: str, *, enclave: str = "/") -> list[str]:
    """The parts after ``@ros2_lv/<domain>/`` of a node's token (its entity id is its node id)."""
    return [zid, str(node_id), str(node_id), NODE, mangle(enclave), mangle(namespace or "/"), mangle(node)]


def entity_parts(
    zid: str,
    node_id: int,
    entity_id: int,
    kind: str,
    namespace: str,
    node: str,
    topic: str,
    dds_type: str,
    type_hash: str,
    qos: Qos,
    *,
    enclave: str = "/",
) -> list[str]:
    """The parts after ``@ros2_lv/<domain>/`` of a publisher's (``MP``) or subscription's (``MS``) token."""
    if kind not in (PUBLISHER, SUBSCRIPTION):
        raise ValueError(f"an entity is a publisher (MP) or a subscription (MS), not {kind!r}")
    head = [zid, str(node_id), str(entity_id), kind, mangle(enclave), mangle(namespace or "/"), mangle(node)]
    return [*head, mangle(topic), mangle(dds_type), mangle(type_hash), qos.key()]


def gid_of(token: str) -> bytes:
    """A publisher's 16-byte GID: a hash of its token (rmw_zenoh hashes the token too, with
    XXH3-128; subscribers only compare GIDs, so any stable hash of the unique token serves)."""
    return hashlib.sha256(token.encode()).digest()[:GID_BYTES]


@dataclass(frozen=True)
class Attachment:
    """What rmw_zenoh attaches to each sample (``rmw_take_with_info``'s message info)."""

    sequence_number: int
    source_timestamp_ns: int
    gid: bytes

    def encode(self) -> bytes:
        """Zenoh's serialization: two little-endian int64, then the GID as a sequence (its
        length as a LEB128 varint, 16 fits one byte, then its bytes)."""
        if len(self.gid) != GID_BYTES:
            raise ValueError(f"a GID is {GID_BYTES} bytes, not {len(self.gid)}")
        return struct.pack("<qqB", self.sequence_number, self.source_timestamp_ns, GID_BYTES) + self.gid

    @classmethod
    def decode(cls, data: bytes) -> Attachment:
        """Reads an attachment as rmw_zenoh writes it.

        Raises:
            DecodeError: Not 33 bytes of two int64 and a 16-byte GID.
        """
        if len(data) != 17 + GID_BYTES or data[16] != GID_BYTES:
            raise DecodeError(
                f"an rmw_zenoh attachment is 33 bytes (sequence number, timestamp, 16-byte GID); got {len(data)}"
            )
        seq, ts = struct.unpack_from("<qq", data)
        return cls(seq, ts, bytes(data[17:]))
