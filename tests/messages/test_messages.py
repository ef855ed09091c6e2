from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import msgspec
import pytest
from hypothesis import given
from hypothesis import strategies as st

from iw_zenoh.convert import spec_from_msg, spec_to_msg
from iw_zenoh.core.spec import IrSensorSpec, LaserSpec, NoiseSpec, RobotSpec, SensorNoise
from iw_zenoh.errors import DecodeError, SpecError
from iw_zenoh.messages import (
    MESSAGE_TYPES,
    Actions,
    Event,
    Hear,
    Heard,
    LabMsg,
    LaserMsg,
    RobotSpecMsg,
    SensorBatch,
    SensorReading,
    WorldInfo,
    WorldState,
    decode,
    encode,
    encode_sensor_batch,
    json_schema,
    readings_of,
)

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@given(
    st.builds(
        Actions,
        tick=st.integers(0, 2**40),
        sim_time_ns=st.integers(0, 2**62),
        robot_id=st.integers(0, 10**6),
        left=finite,
        right=finite,
        end_led=st.booleans(),
    )
)
def test_actions_round_trip(m: Actions) -> None:
    assert decode(encode(m), Actions) == m


@given(
    st.builds(
        Hear,
        robot_id=st.integers(0, 1000),
        messages=st.lists(
            st.builds(Heard, sender=st.integers(0, 1000), distance_m=finite, text=st.text(max_size=100)), max_size=5
        ),
    )
)
def test_hear_round_trips(m: Hear) -> None:
    assert decode(encode(m), Hear) == m


def test_every_message_type_round_trips_and_has_a_schema() -> None:
    samples = {
        WorldState: WorldState(
            revision=1,
            ids=[1],
            x=[1.0],
            y=[2.0],
            heading=[0.5],
            collided=[False],
            rolled_left=[0.0],
            rolled_right=[0.0],
            speed=[0.1],
        ),
        SensorReading: SensorReading(
            robot_id=1,
            proximity_ids=[0],
            proximity_m=[None],
            proximity_legacy=[100.0],
            compass_deg=3.0,
            gps=(1.0, 2.0, 3.0),
        ),
        Event: Event(kind="collision", reason="r", data={"x": 1.5}),
    }
    for kind, msg in samples.items():
        assert decode(encode(msg), kind) == msg
    for kind in MESSAGE_TYPES:
        schema = json_schema(kind)
        assert "$defs" in schema or "properties" in schema
        assert kind.schema.endswith("/1")


def test_a_sensor_batch_of_encoded_readings_decodes_to_the_readings() -> None:
    readings = [
        SensorReading(
            tick=4,
            robot_id=i,
            proximity_ids=[0, 1],
            proximity_m=[None, 0.5],
            proximity_legacy=[100.0, 2.0],
            compass_deg=3.0,
            gps=(1.0, 2.0, 3.0),
        )
        for i in (1, 2)
    ]
    data = encode_sensor_batch(4, 400_000_000, "1-2", [encode(r) for r in readings], 9, [1, 2])
    got = decode(data, SensorBatch)
    assert (got.tick, got.sim_time_ns, got.shard, got.tick_wall_ns) == (4, 400_000_000, "1-2", 9)
    assert got.readings == readings
    assert got.ids == [1, 2]
    assert readings_of(data, {2, 7}) == readings[1:]


def test_a_host_decodes_only_its_own_readings_of_a_batch_and_refuses_a_mislabelled_one() -> None:
    good = encode(
        SensorReading(
            robot_id=2, proximity_ids=[], proximity_m=[], proximity_legacy=[], compass_deg=0.0, gps=(0.0, 0.0, 0.0)
        )
    )
    broken = b'{"robot_id": "not a number"}'
    data = encode_sensor_batch(1, 0, "1-1", [broken, good], 0, [1, 2])
    assert [r.robot_id for r in readings_of(data, {2})] == [2]  # robot 1's reading is not ours to read
    with pytest.raises(DecodeError, match=r"\$.robot_id"):
        readings_of(data, {1})
    with pytest.raises(DecodeError, match="robot 2's"):
        readings_of(encode_sensor_batch(1, 0, "1-1", [good], 0, [3]), {3})
    with pytest.raises(DecodeError, match="2 ids for 1 readings"):
        readings_of(encode_sensor_batch(1, 0, "1-1", [good], 0, [2, 3]), {2})
    # a batch that does not name its readings' robots (an older sender) is read whole
    unnamed = encode(SensorBatch(tick=1, shard="1-1", readings=[decode(good, SensorReading)]))
    assert [r.robot_id for r in readings_of(unnamed, {2})] == [2]


@pytest.mark.parametrize(
    ("data", "why"),
    [
        (b"{nope", "not JSON"),
        (b'{"robot_id": "x"}', "$.robot_id"),
        (b'{"robot_id": 1, "extra": 2}', "unknown field"),
        (b'{"robot_id": -4}', "$.robot_id"),
        (b"[]", "Expected `object`"),
    ],
)
def test_bad_payloads_raise_decode_errors_naming_the_problem(data: bytes, why: str) -> None:
    with pytest.raises(DecodeError, match=__import__("re").escape(why)):
        decode(data, Actions)


def test_specs_convert_both_ways() -> None:
    spec = RobotSpec(
        "chair", id=3, width_m=1.04, height_m=0.66, com=0.81, ir_sensors=(IrSensorSpec(0, 0.72, 0.24, 0.0, 60.0),)
    )
    back = spec_from_msg(spec_to_msg(spec))
    assert back == spec


def test_a_laser_scanner_round_trips_and_a_spec_without_one_reads_as_before_scanners() -> None:
    laser = LaserSpec(2, 0.6, -0.1, 10.0, 240.0, 128, 8.0)
    noise = replace(SensorNoise(), laser_m=NoiseSpec(0.0, 0.03))
    spec = RobotSpec("chair", id=3, ir_sensors=(IrSensorSpec(0),), lasers=(laser,), noise=noise)
    data = encode(spec_to_msg(spec))
    assert spec_from_msg(decode(data, RobotSpecMsg)) == spec
    plain = encode(spec_to_msg(RobotSpec("chair", id=3)))
    assert b"laser" not in plain  # an older reader (unknown fields refused) still reads it
    with pytest.raises(SpecError) as e:
        spec_from_msg(RobotSpecMsg(name="x", lasers=[LaserMsg(id=1, fov_deg=400.0)]))
    assert e.value.field == "laser[1].fov"


def test_a_descriptions_agents_round_trip_and_one_without_them_reads_as_before() -> None:
    lab = LabMsg(name="l", width=5.0, height=5.0)
    robots = [RobotSpecMsg(name="a", id=1), RobotSpecMsg(name="b", id=2)]
    info = WorldInfo(revision=1, lab=lab, period_ns=1, robots=robots, agents=["host-1", ""])
    assert decode(encode(info), WorldInfo) == info
    plain = encode(WorldInfo(revision=1, lab=lab, period_ns=1, robots=robots))
    assert b"agents" not in plain  # an older reader (unknown fields refused) still reads it
    assert decode(plain, WorldInfo).agents is msgspec.UNSET
    bad = encode(info).replace(b'"host-1",', b"")
    with pytest.raises(DecodeError, match="agents has 1 values for 2 robots"):
        decode(bad, WorldInfo)


def test_a_wire_spec_out_of_range_is_refused_naming_the_field() -> None:
    with pytest.raises(SpecError) as e:
        spec_from_msg(RobotSpecMsg(name="x", acceleration_curve=2.0))
    assert e.value.field == "acceleration_curve"


def test_a_nan_is_refused_by_the_receiver_never_read_as_a_number() -> None:
    data = encode(Actions(robot_id=1, left=float("nan")))
    with pytest.raises(DecodeError, match="left"):
        decode(data, Actions)


def test_encoded_messages_validate_against_their_published_json_schemas() -> None:
    import json

    import jsonschema

    samples = [
        WorldState(
            revision=1,
            ids=[1],
            x=[1.0],
            y=[2.0],
            heading=[0.5],
            collided=[False],
            rolled_left=[0.0],
            rolled_right=[0.0],
            speed=[0.1],
        ),
        SensorReading(
            robot_id=1,
            proximity_ids=[0, 1],
            proximity_m=[None, 1.5],
            proximity_legacy=[100.0, 0.7],
            compass_deg=3.0,
            gps=(1.0, 2.0, 3.0),
        ),
        Actions(robot_id=2, left=0.1, right=-0.1),
        Event(kind="collision", reason="r", data={"x": 1.5}),
    ]
    for m in samples:
        jsonschema.validate(json.loads(encode(m)), json_schema(type(m)))
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"robot_id": "x"}, json_schema(Actions))


# Six threads decode the first message of each type recorded in the sample, all at once, in a
# fresh process: the first use of a type, as a role's threads meet it at start (the viewer's
# page pump and Foxglove thread both decoding the world's first description).
_FIRST_DECODES = """
import sys, threading
from pathlib import Path
from iw_zenoh.messages import TOPIC_TYPES, decode
from iw_zenoh.record.reader import open_recording

with open_recording(Path(sys.argv[1])) as rec:
    firsts = {}
    for r in rec.raw(TOPIC_TYPES):
        firsts.setdefault(TOPIC_TYPES[r.kind], r.data)
go = threading.Barrier(6)

def work():
    go.wait()
    for kind, data in firsts.items():
        decode(data, kind)

threads = [threading.Thread(target=work) for _ in range(6)]
for t in threads:
    t.start()
for t in threads:
    t.join()
print(len(firsts))
"""


@pytest.mark.timeout(120)
def test_threads_decoding_a_message_type_for_the_first_time_at_once_do_not_crash_the_process() -> None:
    # msgspec makes a type's decoding on its first use, unlocked: a thread could read it half
    # made and die of SIGSEGV (4 processes in 10 did here before every type was made at import)
    sample = Path(__file__).resolve().parents[2] / "recordings" / "demo-sample.mcap"
    for _ in range(8):
        p = subprocess.run(
            [sys.executable, "-c", _FIRST_DECODES, str(sample)], capture_output=True, text=True, timeout=60
        )
        assert p.returncode == 0, f"exit {p.returncode}:\n{p.stderr[-2000:]}"
        assert int(p.stdout) >= 8, p.stdout  # the sample holds info, states, readings, events...
