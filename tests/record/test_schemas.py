"""Every channel's JSON Schema is one Foxglove's and Lichtblick's parsers accept, and it checks
every message right with a draft-07 validator (Ajv's default) as well as a 2020-12 one."""

from __future__ import annotations

import json
from typing import Any

import jsonschema
import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from iw_zenoh.messages import TOPIC_TYPES, SensorReading, WorldInfo, decode, encode, json_schema
from iw_zenoh.record.channels import key_channel
from iw_zenoh.record.schemas import DRAFT_07, portable
from tests.support.consumer import lichtblick_refusal

TYPES = sorted({cls.schema: cls for cls in TOPIC_TYPES.values()}.items())


def _written(cls: type[msgspec.Struct]) -> dict[str, Any]:
    kind = next(k for k, c in TOPIC_TYPES.items() if c is cls)
    key = {"info": "iw/s/world/info", "state": "iw/s/world/state"}.get(kind)
    if key is not None:
        assert json.loads(key_channel(key).schema) == portable(json_schema(cls))  # what a channel carries
    return portable(json_schema(cls))


@pytest.mark.parametrize(("name", "cls"), TYPES, ids=[n for n, _ in TYPES])
def test_every_message_schema_is_self_contained_draft_07_and_accepted_by_lichtblicks_parser(
    name: str, cls: type[msgspec.Struct]
) -> None:
    schema = _written(cls)
    assert lichtblick_refusal(schema, name) == ""
    assert schema["$schema"] == DRAFT_07
    assert schema["type"] == "object"
    text = json.dumps(schema)
    assert "$ref" not in text
    assert "$defs" not in text
    assert "prefixItems" not in text
    jsonschema.Draft7Validator.check_schema(schema)
    jsonschema.Draft202012Validator.check_schema(schema)
    assert jsonschema.validators.validator_for(schema) is jsonschema.Draft7Validator


def test_msgspecs_own_schema_is_what_lichtblick_refused() -> None:
    # the checker is the parser's mirror: it says of the schemas we used to write what Lichtblick said
    assert lichtblick_refusal(json_schema(WorldInfo), "iw.WorldInfo/1") == (
        'Expected "type": "object" for schema iw.WorldInfo/1, got undefined'
    )


def test_a_sensor_reading_with_tuples_and_nulls_validates_under_draft_07() -> None:
    reading = SensorReading(
        robot_id=1,
        proximity_ids=[0, 1],
        proximity_m=[None, 1.5],
        proximity_legacy=[100.0, 0.7],
        compass_deg=3.0,
        gps=(1.0, 2.0, 3.0),
    )
    schema = _written(SensorReading)
    value = json.loads(encode(reading))
    jsonschema.Draft7Validator(schema).validate(value)
    jsonschema.Draft202012Validator(schema).validate(value)
    value["gps"] = [1.0, 2.0]  # a tuple of the wrong length is still refused
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.Draft7Validator(schema).validate(value)
    value["gps"], value["proximity_m"] = [1.0, 2.0, 3.0], ["near"]  # and a field only a validator types
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.Draft7Validator(schema).validate(value)


def _samples() -> list[msgspec.Struct]:
    from iw_zenoh.convert import lab_to_msg, spec_to_msg
    from iw_zenoh.core.lab import Lab, Wall
    from iw_zenoh.core.spec import LaserSpec, RobotSpec

    chair = RobotSpec("a", id=1, x_m=1.0, y_m=1.0, dir_deg=0.0, lasers=(LaserSpec(3, 0.2, 0.0, 0.0, 180.0, 3, 5.0),))
    lab = Lab("l", 10.0, 10.0, (Wall(((4, 4), (5, 4), (5, 5), (4, 5)), 2.0),))
    return [
        WorldInfo(revision=1, lab=lab_to_msg(lab), period_ns=100_000_000, robots=[spec_to_msg(chair)]),
        SensorReading(
            robot_id=1,
            proximity_ids=[0, 1],
            proximity_m=[None, 1.5],
            proximity_legacy=[100.0, 0.7],
            compass_deg=3.0,
            gps=(1.0, 2.0, 3.0),
        ),
    ]


SAMPLES = _samples()
JSON = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**40), 2**40)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
    max_leaves=6,
)


def _replace(value: Any, path: list[int], new: Any) -> Any:  # noqa: ANN401 (JSON)
    """``value`` with the node ``path`` picks (indices into each container's children) set to ``new``."""
    if not path or not isinstance(value, (dict, list)) or not value:
        return new
    keys = list(value) if isinstance(value, dict) else list(range(len(value)))
    k = keys[path[0] % len(keys)]
    out = dict(value) if isinstance(value, dict) else list(value)
    out[k] = _replace(value[k], path[1:], new)  # type: ignore[index]
    return out


@settings(max_examples=300, deadline=None)
@given(which=st.integers(0, len(SAMPLES) - 1), path=st.lists(st.integers(0, 30), max_size=6), new=JSON)
def test_whatever_the_receiver_decodes_its_written_schema_accepts_in_both_drafts(
    which: int,
    path: list[int],
    new: Any,  # noqa: ANN401 (JSON)
) -> None:
    msg = SAMPLES[which]
    value = _replace(json.loads(encode(msg)), path, new)
    try:
        decode(json.dumps(value).encode(), type(msg))
    except Exception:  # noqa: BLE001 (the mutation made it one the receiver refuses: nothing to hold)
        return
    schema = _written(type(msg))
    jsonschema.Draft7Validator(schema).validate(value)
    jsonschema.Draft202012Validator(schema).validate(value)
