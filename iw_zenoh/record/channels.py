"""The channels a simulation is seen through, the same in a recording and in Foxglove live.

One channel per Zenoh key (topic = the key, encoding ``json``, the JSON Schema of the key's message
type in the form Foxglove's and Lichtblick's parsers accept (:mod:`iw_zenoh.record.schemas`),
metadata ``zenoh_key`` and ``kind``), and the derived Foxglove channels (``/foxglove/scene``,
``/foxglove/tf``, ``/foxglove/laser/...``: :mod:`iw_zenoh.record.foxglove`) that the world's own
messages imply, in Foxglove's own well-known types (protobuf, foxglove-sdk's schemas). The
recorder (:class:`iw_zenoh.record.recording.Recorder`) writes them to MCAP; the live server
(:mod:`iw_zenoh.nodes.foxglove_live`) serves them over the Foxglove WebSocket protocol.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass, field
from typing import Any

import msgspec

from iw_zenoh import keys
from iw_zenoh.errors import IwError
from iw_zenoh.messages import TOPIC_TYPES, SensorReading, WorldInfo, WorldState, decode, json_schema
from iw_zenoh.record.foxglove import DerivedMessage, SceneBuilder
from iw_zenoh.record.schemas import portable

__all__ = [
    "DERIVED_ENCODING",
    "DERIVED_META",
    "ENCODING",
    "SCHEMA_ENCODING",
    "ChannelSpec",
    "Derivation",
    "derived_channel",
    "key_channel",
]

ENCODING = "json"  # every message of the simulation's own keys
SCHEMA_ENCODING = "jsonschema"
DERIVED_ENCODING = "protobuf"  # the derived channels: foxglove-sdk's encoding and schemas
DERIVED_META = {"derived": "foxglove"}  # what marks a channel that is no Zenoh key


@dataclass(frozen=True)
class ChannelSpec:
    """One channel as both the recording and the live server declare it.

    Attributes:
        topic: The Zenoh key, or a derived topic (``/foxglove/scene``).
        schema_name: The message type's schema name (``iw.WorldState/1``); ``""``: a key of no
            known type, recorded schemaless.
        schema: The schema, as bytes (``b""`` with no schema name): a JSON Schema, or for a derived
            channel Foxglove's protobuf ``FileDescriptorSet``.
        metadata: ``zenoh_key`` and ``kind`` for a key, ``derived`` for a derived channel.
        encoding: The messages' encoding (``json``, ``protobuf``).
        schema_encoding: The schema's encoding (``jsonschema``, ``protobuf``).
    """

    topic: str
    schema_name: str
    schema: bytes
    metadata: dict[str, str] = field(default_factory=dict)
    encoding: str = ENCODING
    schema_encoding: str = SCHEMA_ENCODING


@functools.cache
def _schema_bytes(kind: type[msgspec.Struct]) -> bytes:
    return json.dumps(portable(json_schema(kind))).encode()


def key_channel(key: str) -> ChannelSpec:
    """The channel of a Zenoh key: its message type's schema when the key has a known kind."""
    kind = keys.topic_kind(key)
    cls = TOPIC_TYPES.get(kind) if kind else None
    if cls is None:
        return ChannelSpec(key, "", b"", {"zenoh_key": key})
    return ChannelSpec(key, cls.schema, _schema_bytes(cls), {"zenoh_key": key, "kind": kind or ""})


@functools.cache
def _derived_schema(kind: Any) -> tuple[str, bytes]:  # noqa: ANN401 (any foxglove-sdk message class)
    schema = kind.get_schema()
    return schema.name, bytes(schema.data)


def derived_channel(topic: str, msg: DerivedMessage) -> ChannelSpec:
    """The channel of a derived topic carrying ``msg``'s type (foxglove-sdk's protobuf schema)."""
    # foxglove-sdk's stubs declare its classes unhashable (__hash__ = None on instances); a class hashes
    name, data = _derived_schema(type(msg))  # type: ignore[arg-type]
    return ChannelSpec(topic, name, data, dict(DERIVED_META), DERIVED_ENCODING, DERIVED_ENCODING)


class Derivation:
    """The Foxglove scene and transforms a stream of simulation messages implies.

    Feed it every message in the order received (:meth:`derive`); it keeps what it needs (the
    robots' specs from ``world/info``, their last poses) to draw the next ones.
    """

    def __init__(self) -> None:
        self.scene = SceneBuilder()

    def derive(self, key: str, data: bytes) -> list[tuple[ChannelSpec, bytes]]:
        """The derived messages ``data`` on ``key`` implies, each with its channel.

        A malformed message implies nothing (it is recorded as received all the same).

        Args:
            key: The Zenoh key it came on.
            data: The payload as published.

        Returns:
            ``(channel, payload)`` pairs, in the order to publish them (the payload encoded in
            the channel's encoding).
        """
        kind = keys.topic_kind(key)
        try:
            if kind == "info":
                out = self.scene.on_info(decode(data, WorldInfo))
            elif kind == "state":
                out = self.scene.on_state(decode(data, WorldState))
            elif kind == "sensors":
                out = self.scene.on_sensors(decode(data, SensorReading))
            else:
                return []
        except IwError:
            return []
        return [(derived_channel(topic, msg), msg.encode()) for topic, msg in out]
