"""Event kinds and their typed payloads: one payload type per kind, built and read back the same,
the wire shape (a JSON object in ``data``) unchanged, and a wrong payload refused with a reason."""

from __future__ import annotations

import json

import pytest

from iw_zenoh.core.modes import Mode, Profile
from iw_zenoh.errors import DecodeError
from iw_zenoh.messages import (
    EVENT_PAYLOADS,
    AgentLostData,
    BadMessageData,
    CollisionData,
    Event,
    EventData,
    EventKind,
    LaggardData,
    LegacyRefusedData,
    NoData,
    ObstacleData,
    RadioDroppedData,
    RefusedData,
    RegisteredData,
    SerialLinkData,
    Tick,
    WorldInfo,
    decode,
    encode,
    event_payload,
    json_schema,
    make_event,
)

EXAMPLES: dict[type[EventData], EventData] = {
    NoData: NoData(),
    BadMessageData: BadMessageData(count=17),
    CollisionData: CollisionData(x=1.5, y=2.0, walls=[4], robots=[2]),
    RegisteredData: RegisteredData(agent="agent-1"),
    RefusedData: RefusedData(name="chair", agent="agent-1"),
    AgentLostData: AgentLostData(agent="agent-1"),
    ObstacleData: ObstacleData(name="box"),
    LaggardData: LaggardData(robots=[1, 3]),
    RadioDroppedData: RadioDroppedData(too_long=1, over_budget=3),
    LegacyRefusedData: LegacyRefusedData(peer="127.0.0.1:5000"),
    SerialLinkData: SerialLinkData(port="/dev/ttyUSB0"),
}


def test_every_event_kind_has_a_payload_type() -> None:
    assert set(EVENT_PAYLOADS) == set(EventKind)
    assert set(EVENT_PAYLOADS.values()) == set(EXAMPLES)


@pytest.mark.parametrize("kind", list(EventKind))
def test_an_event_built_from_its_payload_reads_back_the_same_through_the_wire(kind: EventKind) -> None:
    payload = EXAMPLES[EVENT_PAYLOADS[kind]]
    ev = make_event(kind, payload, reason="why", tick=3, sim_time_ns=300, robot_id=1, key="k", source="world")
    back = decode(encode(ev), Event)
    assert back == ev
    assert back.kind is kind
    assert event_payload(back) == payload
    assert event_payload(back, EVENT_PAYLOADS[kind]) == payload


def test_the_collision_payload_keeps_the_wire_shape_old_recordings_have() -> None:
    ev = make_event(EventKind.COLLISION, CollisionData(x=1.0, y=2.5, walls=[0], robots=[]), robot_id=1)
    assert b'"kind":"collision"' in encode(ev)
    assert b'"data":{"x":1.0,"y":2.5,"walls":[0],"robots":[]}' in encode(ev)
    old = b'{"tick":7,"sim_time_ns":700,"kind":"collision","reason":"r","robot_id":1,"data":{"x":3,"y":4.5,"walls":[],"robots":[2]}}'
    assert event_payload(decode(old, Event), CollisionData) == CollisionData(x=3.0, y=4.5, walls=[], robots=[2])


def test_a_payload_without_data_is_an_empty_object_and_radio_drops_leave_out_zero_counts() -> None:
    assert make_event(EventKind.STARTED, reason="go").data == {}
    assert make_event(EventKind.RADIO_DROPPED, RadioDroppedData(over_budget=2)).data == {"over_budget": 2}


@pytest.mark.parametrize(
    ("data", "field"),
    [
        ({"x": "far", "y": 1.0}, "$.x"),
        ({"y": 1.0}, "x"),
        ({"x": 1.0, "y": 1.0, "walls": [0], "robots": [], "speed": 2.0}, "speed"),
    ],
)
def test_an_event_with_a_wrong_payload_is_refused_with_a_reason(data: dict[str, object], field: str) -> None:
    ev = Event(kind=EventKind.COLLISION, reason="r", data=data)
    with pytest.raises(DecodeError, match="collision") as err:
        event_payload(ev)
    assert field in str(err.value)


def test_a_payload_of_another_kind_is_refused_when_built_and_when_read() -> None:
    with pytest.raises(TypeError, match="CollisionData"):
        make_event(EventKind.COLLISION, ObstacleData(name="box"))
    with pytest.raises(TypeError, match="RefusedData"):
        make_event(EventKind.REFUSED)  # a refusal names what it refused, even if empty
    ev = make_event(EventKind.OBSTACLE, ObstacleData(name="box"))
    with pytest.raises(TypeError, match="ObstacleData"):
        event_payload(ev, CollisionData)


def test_an_event_of_an_unknown_kind_does_not_decode() -> None:
    with pytest.raises(DecodeError, match="kind"):
        decode(b'{"kind":"mystery"}', Event)
    with pytest.raises(DecodeError, match="mystery"):
        event_payload(Event(kind="mystery"))  # type: ignore[arg-type]


def test_modes_and_profiles_keep_their_wire_values_and_the_schemas_list_them() -> None:
    assert [m.value for m in Mode] == ["realtime", "lockstep"]
    assert [p.value for p in Profile] == ["native", "ciberrato"]
    assert b'"mode":"lockstep"' in encode(Tick(period_ns=1, mode=Mode.LOCKSTEP))
    assert decode(b'{"period_ns":1,"mode":"lockstep"}', Tick).mode is Mode.LOCKSTEP
    with pytest.raises(DecodeError, match="mode"):
        decode(b'{"period_ns":1,"mode":"fast"}', Tick)
    text = json.dumps(json_schema(WorldInfo))
    assert all(v.value in text for v in [*Mode, *Profile])
    assert all(k.value in json.dumps(json_schema(Event)) for k in EventKind)
