"""What Foxglove and Lichtblick make of a channel: their schema rules, as tests check them.

:func:`lichtblick_refusal` mirrors ``packages/mcap-support/src/parseJsonSchema.ts`` of
Lichtblick-Suite/lichtblick (Foxglove's open-source studio has the same), the parser those tools
read every ``jsonschema`` channel with; the rules are written down in docs/recording.md. A
``protobuf`` channel is read by Foxglove's protobuf support: :func:`proto_decode` decodes a message
with the channel's own ``FileDescriptorSet``, as they do. :func:`check_recording` applies both to
every channel of a recording, and validates every JSON message against its schema with a draft-07
validator (Ajv's default mode) and a 2020-12 one.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jsonschema
from google.protobuf import descriptor_pb2, descriptor_pool, json_format, message_factory
from mcap.reader import make_reader

_ITEM_TYPES = ("boolean", "string", "number", "integer", "object")


def lichtblick_refusal(schema: Any, name: str) -> str:  # noqa: ANN401 (any JSON value)
    """What Lichtblick's parser throws on ``schema`` (``""``: it accepts it), in its own words."""
    if not isinstance(schema, dict):
        return f"Invalid schema, expected JSON object, got {type(schema).__name__}"
    return _object(schema, name, [])


def _js(d: dict[str, Any], key: str) -> str:
    """``JSON.stringify(d[key])`` as a template string shows it (``undefined`` when absent)."""
    return json.dumps(d[key]) if key in d else "undefined"


def _object(schema: dict[str, Any], type_name: str, path: list[str]) -> str:
    if schema.get("type") != "object":
        return f'Expected "type": "object" for schema {type_name}, got {_js(schema, "type")}'
    for field, fs in (schema.get("properties") or {}).items():
        where = ".".join([*path, field])
        if isinstance(fs.get("oneOf"), list):
            if all(isinstance(alt.get("const"), (int, float)) for alt in fs["oneOf"]):
                continue
            return f"Unsupported type for {where}: oneOf alternatives must have number values"
        kind = fs.get("type")
        if kind in ("boolean", "number", "integer"):
            continue
        if kind == "string":
            if fs.get("contentEncoding") not in (None, "base64"):
                return f"Unsupported contentEncoding {json.dumps(fs['contentEncoding'])} in {where}"
        elif kind == "object":
            if err := _object(fs, f"{type_name}.{field}", [*path, field]):
                return err
        elif kind == "array":
            items = fs.get("items")
            if not isinstance(items, dict):  # the parser reads items.type: undefined items throw
                return f"Cannot read properties of {json.dumps(items)} (reading 'type') for {where}"
            if items.get("type") == "string" and items.get("contentEncoding") is not None:
                return f"Unsupported contentEncoding for array item {where}"
            if items.get("type") not in _ITEM_TYPES:
                return f"Unsupported type {_js(items, 'type')} for array item {where}"
            if items["type"] == "object" and (err := _object(items, f"{type_name}.{field}", [*path, field])):
                return err
        else:
            return f"Unsupported type {_js(fs, 'type')} for {where}"
    return ""


def proto_message(descriptor_set: bytes, name: str, data: bytes) -> Any:  # noqa: ANN401 (a generated class)
    """A protobuf message decoded with its channel's ``FileDescriptorSet`` (as Foxglove does)."""
    files = descriptor_pb2.FileDescriptorSet.FromString(descriptor_set)
    pool = descriptor_pool.DescriptorPool()
    for f in files.file:
        pool.Add(f)
    cls = message_factory.GetMessageClass(pool.FindMessageTypeByName(name))
    return cls.FromString(data)


def proto_decode(descriptor_set: bytes, name: str, data: bytes) -> dict[str, Any]:
    """:func:`proto_message` as a dictionary (field names as in the schema)."""
    msg = proto_message(descriptor_set, name, data)
    out: dict[str, Any] = json_format.MessageToDict(msg, preserving_proto_field_name=True)
    return out


def check_recording(path: Path) -> dict[str, int]:
    """Checks every channel of ``path`` as the consumers read it; messages checked per topic.

    Raises:
        AssertionError: A schema Lichtblick refuses, a JSON message its schema refuses (draft-07 or
            2020-12), a protobuf message its descriptor does not decode, a channel of another
            encoding.
    """
    checked: dict[str, int] = {}
    validators: dict[int, tuple[Any, Any]] = {}
    with path.open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            assert schema is not None, f"{channel.topic}: no schema"
            if channel.message_encoding == "json":
                assert schema.encoding == "jsonschema", f"{channel.topic}: {schema.encoding}"
                if schema.id not in validators:
                    doc = json.loads(schema.data)
                    assert not (err := lichtblick_refusal(doc, schema.name)), f"{channel.topic}: {err}"
                    assert doc.get("$schema") == "http://json-schema.org/draft-07/schema#", channel.topic
                    jsonschema.Draft7Validator.check_schema(doc)
                    jsonschema.Draft202012Validator.check_schema(doc)
                    assert jsonschema.validators.validator_for(doc) is jsonschema.Draft7Validator
                    validators[schema.id] = (jsonschema.Draft7Validator(doc), jsonschema.Draft202012Validator(doc))
                value = json.loads(message.data)
                for v in validators[schema.id]:
                    v.validate(value)
            else:
                assert (channel.message_encoding, schema.encoding) == ("protobuf", "protobuf"), channel.topic
                proto_decode(schema.data, schema.name, message.data)
            checked[channel.topic] = checked.get(channel.topic, 0) + 1
    return checked
