"""Every Zenoh decoder fed what a hostile or unlucky sender would send: random bytes, JSON of the
wrong shape, and schema-valid messages whose values disagree (arrays of different lengths, a robot
named twice, huge or negative numbers, non-ASCII text, NaN and infinities written as JSON cannot
hold them). Nothing but DecodeError escapes, every DecodeError has a reason, and what decodes is
consistent (what the nodes act on without looking again)."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any, TypeVar

import msgspec
import pytest
from hypothesis import example, given
from hypothesis import strategies as st
from msgspec.structs import replace

from iw_zenoh.errors import DecodeError
from iw_zenoh.messages import (
    MESSAGE_TYPES,
    ActionBatch,
    Actions,
    ChairReading,
    Control,
    DriveInput,
    DriveState,
    Event,
    Hear,
    Heard,
    Hit,
    LabMsg,
    LaserMsg,
    LaserScan,
    Message,
    PoseReport,
    Proposed,
    RadioBatch,
    RegisterReply,
    RegisterRequest,
    RobotSpecMsg,
    Say,
    SensorBatch,
    SensorReading,
    Tick,
    Verdict,
    WorldInfo,
    WorldState,
    decode,
    encode,
    encode_sensor_batch,
    event_payload,
    readings_of,
    stamp_of,
)


def _reading(rid: int, tick: int = 3) -> SensorReading:
    return SensorReading(
        tick=tick,
        robot_id=rid,
        proximity_ids=[0, 1],
        proximity_m=[None, 0.5],
        proximity_legacy=[100.0, 2.0],
        compass_deg=10.0,
        beacons_deg=[None, 4.0],
        gps=(1.0, 2.0, 0.5),
        encoders=(3, 4),
        bumpers=[False],
    )


SAMPLES: dict[type[Message], Message] = {
    RegisterRequest: RegisterRequest(
        spec=RobotSpecMsg(name="chair", id=2, x_m=1.0, y_m=1.0, lasers=[LaserMsg(id=0, beams=3)]),
        agent="a",
        request_id="1",
    ),
    RegisterReply: RegisterReply(ok=True, robot_id=2, spec=RobotSpecMsg(name="chair", id=2)),
    WorldInfo: WorldInfo(
        revision=1,
        lab=LabMsg(name="lab", width=10.0, height=5.0),
        period_ns=100_000_000,
        robots=[RobotSpecMsg(name="a", id=1), RobotSpecMsg(name="b", id=2)],
    ),
    Tick: Tick(tick=3, period_ns=100_000_000),
    Proposed: Proposed(
        tick=3,
        revision=1,
        ids=[1, 2],
        x=[1.0, 2.0],
        y=[1.0, 2.0],
        heading=[0.0, 1.0],
        next_x=[1.1, 2.1],
        next_y=[1.0, 2.0],
        next_heading=[0.0, 1.0],
        linear=[0.1, 0.1],
        active=[True, True],
        rolled_left=[0.1, 0.1],
        rolled_right=[0.1, 0.1],
    ),
    Verdict: Verdict(
        tick=3, revision=1, ids=[1, 2], collided=[True, True], hits=[Hit(robot_id=1, other=2), Hit(robot_id=2, wall=0)]
    ),
    WorldState: WorldState(
        tick=3,
        revision=1,
        ids=[1, 2],
        x=[1.0, 2.0],
        y=[1.0, 2.0],
        heading=[0.0, 1.0],
        collided=[False, True],
        rolled_left=[0.1, 0.0],
        rolled_right=[0.1, 0.0],
        speed=[0.3, 0.0],
    ),
    Actions: Actions(tick=3, robot_id=1, left=0.1, right=-0.1),
    ActionBatch: ActionBatch(
        tick=3, agent="a", actions=[Actions(tick=3, robot_id=1, left=0.1), Actions(tick=3, robot_id=2, right=0.1)]
    ),
    PoseReport: PoseReport(tick=3, robot_id=1, x=1.0, y=2.0, dir_deg=90.0),
    ChairReading: ChairReading(
        tick=3, robot_id=1, pose=(1.0, 2.0, 90.0), encoders=(10, -4), proximity_ids=[0, 1], proximity_m=[0.5, None]
    ),
    SensorReading: replace(_reading(1), lasers=[LaserScan(id=0, ranges=[1.5, None, 2.0])]),
    SensorBatch: SensorBatch(tick=3, shard="1-1", readings=[_reading(1), _reading(2)], ids=[1, 2]),
    Say: Say(tick=3, robot_id=1, text="hello"),
    Hear: Hear(tick=3, robot_id=1, messages=[Heard(sender=2, distance_m=1.5, text="hi")]),
    RadioBatch: RadioBatch(
        tick=3,
        hear=[
            Hear(tick=3, robot_id=1, messages=[Heard(sender=2, distance_m=1.5, text="hi")]),
            Hear(tick=3, robot_id=2, messages=[]),
        ],
    ),
    Control: Control(command="step", steps=2),
    Event: Event(kind="collision", reason="r", robot_id=1, data={"x": 1.0, "y": 2.0}),
    DriveInput: DriveInput(
        tick=3, robot_id=1, driver="page-1", seq=4, x=-0.5, y=1.0, buttons=1, level=3, goto=(2.0, 3.5), assist="safe"
    ),
    DriveState: DriveState(
        tick=3,
        robot_id=1,
        driver="page-1",
        seq=4,
        level=3,
        assist="safe",
        v_mps=0.2,
        w_radps=-0.1,
        input_v_mps=0.4,
        input_w_radps=-0.1,
        intervened=True,
        nearest_m=0.8,
        goal=(2.0, 3.5),
    ),
}

KINDS = list(MESSAGE_TYPES)

# a value a hostile sender may put anywhere: huge and negative numbers, text where numbers go,
# non-ASCII text, containers of the wrong shape, lists longer or shorter than their neighbours
ADVERSARIAL = st.one_of(
    st.sampled_from([10**30, -(10**30), 2**63, 2**64, -1, -(2**63) - 1, 1e308, -1e308, 5e-324, 0, True, None]),
    st.sampled_from(["", "٣", "𝟕", "é" * 200, "\x00", "NaN", "Infinity", "1e400"]),
    st.integers(),
    st.floats(allow_nan=False, allow_infinity=False),
    st.text(max_size=20),
    st.lists(st.one_of(st.integers(-5, 5), st.floats(-1e308, 1e308), st.booleans(), st.none()), max_size=5),
    st.dictionaries(st.text(max_size=5), st.integers(), max_size=3),
)
# JSON has no NaN or infinity: a sender that writes them anyway writes these tokens
RAW_TOKENS = ["NaN", "Infinity", "-Infinity", "1e400", "-1e400", "1" + "0" * 400, "nan"]

JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False, allow_infinity=False) | st.text(),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)


R = TypeVar("R")


def _attempt(fn: Callable[[], R]) -> tuple[R | None, str]:
    """What ``fn`` gives, or the reason of the DecodeError it raises (anything else escapes)."""
    try:
        return fn(), ""
    except DecodeError as e:
        return None, str(e) or "(no reason)"  # an empty reason must fail its test


def _refused_with_reason(data: bytes, kind: type[Message]) -> Message | None:
    """Decodes; only DecodeError may escape, and it must say why."""
    msg, why = _attempt(lambda: decode(data, kind))
    assert msg is not None or why.startswith(f"{kind.schema}: ") and why.strip() != kind.schema + ":", why
    return msg


def _ints(doc: Any) -> list[int]:
    if isinstance(doc, dict):
        return [i for v in doc.values() for i in _ints(v)]
    if isinstance(doc, list | tuple):
        return [i for v in doc for i in _ints(v)]
    return [doc] if isinstance(doc, int) and not isinstance(doc, bool) else []


def _consistent(msg: Message) -> None:
    """What every node assumes of a decoded message, without looking again."""
    doc = msgspec.to_builtins(msg)
    doc.pop("data", None)  # an event's payload is checked by event_payload
    assert all(-(2**63) <= i < 2**63 for i in _ints(doc)), "every integer fits numpy's and MCAP's 64 bits"
    if isinstance(msg, WorldState | Proposed | Verdict):
        fields = [f for f in msg.__struct_fields__ if isinstance(getattr(msg, f), list) and f != "hits"]
        if isinstance(msg, Proposed) and not msg.rolled_left:  # an older world's: no distances rolled
            fields = [f for f in fields if not f.startswith("rolled")]
        assert {len(getattr(msg, f)) for f in fields} == {len(msg.ids)}
        assert len(set(msg.ids)) == len(msg.ids)
    if isinstance(msg, Verdict):
        assert all(h.robot_id in msg.ids and (h.other < 0 or h.other in msg.ids) for h in msg.hits)
    if isinstance(msg, SensorReading):
        assert len(msg.proximity_m) == len(msg.proximity_legacy) == len(msg.proximity_ids)
    if isinstance(msg, SensorBatch) and msg.ids:
        assert msg.ids == [r.robot_id for r in msg.readings]
    if isinstance(msg, Event):
        payload, why = _attempt(lambda: event_payload(msg))
        assert payload is not None or why != "(no reason)"


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: k.__name__)
def test_every_sample_round_trips(kind: type[Message]) -> None:
    assert decode(encode(SAMPLES[kind]), kind) == SAMPLES[kind]


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: k.__name__)
@given(data=st.binary(max_size=200))
@example(data=b"")
@example(data=b'{"tick": 100000000000000000000000, "sim_time_ns": -5}')
@example(data=b"\xff\xfe{")
@example(data=b'{"tick": 1' + b"1" * 5000 + b"}")
def test_random_bytes_are_refused_with_a_reason(kind: type[Message], data: bytes) -> None:
    _refused_with_reason(data, kind)
    assert all(0 <= v < 2**63 for v in stamp_of(data))


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: k.__name__)
@given(doc=JSON)
def test_json_of_any_shape_is_refused_with_a_reason_or_is_consistent(kind: type[Message], doc: Any) -> None:
    msg = _refused_with_reason(json.dumps(doc).encode(), kind)
    if msg is not None:
        _consistent(msg)


def _paths(doc: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every place in a JSON document a value sits (and every list's end, to grow it)."""
    out = [prefix] if prefix else []
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        out.append((*prefix, len(doc)))
        for i, v in enumerate(doc):
            out += _paths(v, (*prefix, i))
    return out


def _put(doc: Any, path: tuple[Any, ...], value: Any) -> Any:
    """``doc`` with ``value`` at ``path`` (appended when the path is a list's end; ``...``
    deletes)."""
    doc = json.loads(json.dumps(doc))
    *head, last = path
    where = doc
    for p in head:
        where = where[p]
    if isinstance(where, list) and last == len(where):
        if value is not ...:
            where.append(value)
    elif value is ...:
        del where[last]
    else:
        where[last] = value
    return doc


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: k.__name__)
@given(data=st.data())
def test_a_sample_with_any_value_changed_is_refused_with_a_reason_or_is_consistent(
    kind: type[Message], data: st.DataObject
) -> None:
    doc = json.loads(encode(SAMPLES[kind]))
    for _ in range(data.draw(st.integers(1, 3))):
        paths = _paths(doc)
        if not paths:
            break
        path = data.draw(st.sampled_from(paths))
        doc = _put(doc, path, data.draw(st.one_of(ADVERSARIAL, st.just(...))))
    text = json.dumps(doc)
    if data.draw(st.booleans()):  # and perhaps a token JSON has no place for, where a value was
        token = data.draw(st.sampled_from(RAW_TOKENS))
        text = text.replace("1.0", token, 1)
    msg = _refused_with_reason(text.encode(), kind)
    if msg is not None:
        _consistent(msg)


@pytest.mark.parametrize(
    ("kind", "field", "value", "why"),
    [
        (WorldState, "x", [1.0], "x has 1 values for 2 robots"),
        (WorldState, "collided", [True, False, True], "collided has 3 values for 2 robots"),
        (WorldState, "ids", [1, 1], "ids name robot 1 twice"),
        (WorldState, "speed", [1e300, 1.0], "speed holds a value beyond"),
        (Proposed, "next_heading", [], "next_heading has 0 values for 2 robots"),
        (Proposed, "rolled_left", [0.0], "rolled_left has 1 values for 2 robots"),
        (Proposed, "rolled_left", [], "rolled_left has 0 values for 2 robots"),  # rolled_right has 2
        (Proposed, "active", [True], "active has 1 values for 2 robots"),
        (Verdict, "collided", [True], "collided has 1 values for 2 robots"),
        (Verdict, "hits", [{"robot_id": 7, "wall": 1}], "not in ids"),
        (Verdict, "hits", [{"robot_id": 1, "other": -5}], "hits[0].other"),
        (SensorReading, "proximity_legacy", [1.0], "2 proximity_ids for 2 proximity_m and 1 proximity_legacy"),
        (SensorBatch, "ids", [2, 1], "ids do not name each reading's robot"),
        (ActionBatch, "actions", [{"robot_id": 4}, {"robot_id": 4}], "actions name robot 4 twice"),
        (RadioBatch, "hear", [{"robot_id": 4}, {"robot_id": 4}], "hear name robot 4 twice"),
        (PoseReport, "x", 1e300, "x must be a finite number within"),
        (WorldInfo, "robots", [{"name": "a", "id": 3}, {"name": "b", "id": 3}], "robots name robot 3 twice"),
        (WorldInfo, "seed", -1, "$.seed"),
        (WorldState, "tick", 2**64, "$.tick"),
        (WorldState, "ids", [1, 2**63], "$.ids[1]"),
        (WorldInfo, "lab", {"name": "l", "width": 1.0, "height": 1.0, "walls": [{"corners": [[0, 0]]}]}, "3 corners"),
    ],
)
def test_inconsistent_messages_are_refused_naming_the_problem(
    kind: type[Message], field: str, value: Any, why: str
) -> None:
    doc = json.loads(encode(SAMPLES[kind]))
    doc[field] = value
    with pytest.raises(DecodeError, match=__import__("re").escape(why)):
        decode(json.dumps(doc).encode(), kind)


def test_every_batched_message_built_by_our_own_code_still_builds() -> None:
    for kind, msg in SAMPLES.items():
        assert msgspec.structs.replace(msg) == msg, kind
    empty = WorldState(
        ids=[], x=[], y=[], heading=[], collided=[], rolled_left=[], rolled_right=[], speed=[], revision=0
    )
    assert empty.ids == []
    with pytest.raises(ValueError, match="x has 1 values for 0 robots"):
        WorldState(
            ids=[], x=[1.0], y=[], heading=[], collided=[], rolled_left=[], rolled_right=[], speed=[], revision=0
        )


@given(
    readings=st.lists(st.one_of(st.binary(max_size=40), JSON.map(lambda d: json.dumps(d).encode())), max_size=4),
    ids=st.lists(st.integers(-3, 2**64), max_size=5),
    wanted=st.sets(st.integers(0, 5), max_size=3),
)
def test_the_sensor_batch_fast_path_refuses_with_a_reason_or_gives_only_wanted_consistent_readings(
    readings: list[bytes], ids: list[int], wanted: set[int]
) -> None:
    # the readings may not even be JSON: they are spliced into the batch as they are
    try:
        data = encode_sensor_batch(3, 0, "1-1", readings, 0, ids)
    except (msgspec.EncodeError, OverflowError):
        return  # our own encoder refuses to write an int beyond 64 bits
    got, why = _attempt(lambda: readings_of(data, wanted))
    assert got is not None or why != "(no reason)"
    for r in got or []:
        assert r.robot_id in wanted
        _consistent(r)


@given(data=st.binary(max_size=300), wanted=st.sets(st.integers(0, 5), max_size=3))
@example(data=encode_sensor_batch(1, 0, "1-1", [encode(_reading(1)), encode(_reading(1))], 0, [1, 1]), wanted={1})
@example(data=encode(SensorBatch(readings=[_reading(1), _reading(2)], shard="s")), wanted={1})
def test_the_sensor_batch_fast_path_refuses_random_bytes_with_a_reason(data: bytes, wanted: set[int]) -> None:
    got, why = _attempt(lambda: readings_of(data, wanted))
    assert got is not None or why != "(no reason)"
    assert all(r.robot_id in wanted for r in got or [])


@given(data=st.dictionaries(st.text(max_size=8), JSON, max_size=4), kind=st.text(max_size=12))
def test_an_event_payload_of_any_shape_is_refused_with_a_reason(data: dict[str, Any], kind: str) -> None:
    doc = {"kind": kind, "data": data}
    ev = _refused_with_reason(json.dumps(doc).encode(), Event)
    if isinstance(ev, Event):
        payload, why = _attempt(lambda: event_payload(ev))
        assert payload is not None or why != "(no reason)"
