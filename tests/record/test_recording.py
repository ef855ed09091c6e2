from __future__ import annotations

import io
from pathlib import Path

from mcap.reader import make_reader

from iw_zenoh import keys
from iw_zenoh.messages import Actions, WorldState, encode
from iw_zenoh.record.recording import SIM_INDEX, Recorder
from iw_zenoh.record.tools import check, recover
from tests.support.consumer import proto_decode


def _state(tick: int) -> bytes:
    return encode(
        WorldState(
            tick=tick,
            sim_time_ns=tick * 100_000_000,
            revision=1,
            ids=[1],
            x=[1.0 * tick],
            y=[2.0],
            heading=[0.0],
            collided=[False],
            rolled_left=[0.0],
            rolled_right=[0.0],
            speed=[0.0],
        )
    )


def _write(path: Path, ticks: int, *, finish: bool = True) -> Recorder:
    f = path.open("wb")  # closed here, or (a crash) by the test
    rec = Recorder(f, {"iw.scenario": {"name": "unit"}}, chunk_size=2000, scene=False)
    for t in range(1, ticks + 1):
        rec.add(keys.state("s"), _state(t), 1_000_000_000 + t * 100_000_000)
        rec.add(
            keys.actions("s", 1), encode(Actions(tick=t, robot_id=1, left=0.1)), 1_000_000_000 + t * 100_000_000 + 5
        )
        if t % 10 == 0:
            rec.flush()
    rec.add(keys.event("s", "bad-message"), b"{not json", 9_000_000_000)
    if finish:
        rec.finish()
        f.close()
    else:
        f.flush()
        f.close()  # the process dies: no finish, the unflushed chunk never reaches the file
    return rec


def test_every_key_becomes_a_channel_with_schema_and_times(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    _write(path, 30)
    with path.open("rb") as f:
        reader = make_reader(f)
        msgs = list(reader.iter_messages())
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    topics = {c.topic for _, c, _ in msgs}
    assert topics == {"iw/s/world/state", "iw/s/robot/1/actions", "iw/s/events/bad-message"}
    states = [(s, m) for s, c, m in msgs if c.topic == "iw/s/world/state"]
    assert states[0][0] is not None
    assert states[0][0].name == "iw.WorldState/1"
    assert states[4][1].publish_time == 500_000_000  # simulation time
    assert states[4][1].log_time == 1_500_000_000  # receive time
    bad = next(m for _, c, m in msgs if c.topic.endswith("bad-message"))
    assert bad.data == b"{not json"  # recorded byte for byte, even malformed
    assert meta["iw.scenario"] == {"name": "unit"}
    assert meta["iw.counts"]["iw/s/world/state"] == "30"
    assert SIM_INDEX in meta


def test_doctor_says_whole_or_cut_off(tmp_path: Path) -> None:
    whole = tmp_path / "whole.mcap"
    _write(whole, 20)
    h = check(whole)
    assert h.whole
    assert h.counts_match
    assert h.messages == 41
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    bad = check(cut)
    assert not bad.whole
    assert "cut off" in bad.reason
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"hello world, not mcap")
    assert "not an MCAP file" in check(junk).reason


def test_recover_saves_every_flushed_message_of_a_cut_off_file(tmp_path: Path) -> None:
    path = tmp_path / "crash.mcap"
    rec = _write(path, 35, finish=False)  # flushed every 10 ticks; then the process "dies"
    data = path.read_bytes()
    out = io.BytesIO()
    r = recover(io.BytesIO(data), out, len(data))
    assert r.messages >= 60  # the 30 flushed ticks: 60 messages
    assert r.per_topic["iw/s/world/state"] >= 30
    out.seek(0)
    rebuilt = tmp_path / "rebuilt.mcap"
    rebuilt.write_bytes(out.getvalue())
    assert check(rebuilt).whole
    assert sum(rec.counts.values()) - r.messages <= 11  # lost at most what was not yet flushed


def test_a_recording_carries_a_foxglove_scene_that_validates_against_its_schema(tmp_path: Path) -> None:

    from iw_zenoh.convert import lab_to_msg, spec_to_msg
    from iw_zenoh.core.lab import Lab, Wall
    from iw_zenoh.core.spec import RobotSpec
    from iw_zenoh.messages import SensorReading, WorldInfo

    path = tmp_path / "scene.mcap"
    lab = Lab("l", 10.0, 10.0, (Wall(((4, 4), (5, 4), (5, 5), (4, 5)), 2.0),))
    info = WorldInfo(
        revision=1,
        lab=lab_to_msg(lab),
        period_ns=100_000_000,
        robots=[spec_to_msg(RobotSpec("a", id=1, x_m=1.0, y_m=1.0, dir_deg=0.0))],
    )
    with path.open("wb") as f:
        rec = Recorder(f)
        rec.add(keys.info("s"), encode(info), 1)
        rec.add(keys.state("s"), _state(1), 2)
        reading = SensorReading(
            tick=1,
            sim_time_ns=100_000_000,
            robot_id=1,
            proximity_ids=[0, 1, 2, 3],
            proximity_m=[1.0, None, 2.0, 0.5],
            proximity_legacy=[1.0] * 4,
            compass_deg=0.0,
            gps=(1.0, 2.0, 0.0),
        )
        rec.add(keys.sensors("s", 1), encode(reading), 3)
        rec.finish()
    with path.open("rb") as f:
        msgs = list(make_reader(f).iter_messages())
    scene = [(s, m) for s, c, m in msgs if c.topic == "/foxglove/scene"]
    tf = [(s, m) for s, c, m in msgs if c.topic == "/foxglove/tf"]
    assert {s.name for s, _ in scene} == {"foxglove.SceneUpdate"}
    assert {s.name for s, _ in tf} == {"foxglove.FrameTransform"}
    # Foxglove's own types, in its protobuf encoding: decoded with the channel's own descriptors
    assert {s.encoding for s, _ in scene + tf} == {"protobuf"}
    decoded = [proto_decode(s.data, s.name, m.data) for s, m in scene]
    assert [e["id"] for m in decoded for e in m["entities"]] == ["walls", "robot/1", "cones/1"]
    assert all(proto_decode(s.data, s.name, m.data)["child_frame_id"] == "robot1" for s, m in tf)
    body = next(e for m in decoded for e in m["entities"] if e["id"] == "robot/1")
    assert body["cubes"][0]["size"]["x"] == 1.0


def test_a_laser_scan_is_recorded_as_a_foxglove_laser_scan_in_its_robots_frame(tmp_path: Path) -> None:
    import math

    from iw_zenoh.convert import lab_to_msg, spec_to_msg
    from iw_zenoh.core.lab import Lab
    from iw_zenoh.core.spec import LaserSpec, RobotSpec
    from iw_zenoh.messages import LaserScan, SensorReading, WorldInfo

    path = tmp_path / "laser.mcap"
    spec = RobotSpec("a", id=1, x_m=1.0, y_m=1.0, dir_deg=0.0, lasers=(LaserSpec(3, 0.2, 0.0, 0.0, 180.0, 3, 5.0),))
    info = WorldInfo(
        revision=1, lab=lab_to_msg(Lab("l", 10.0, 10.0)), period_ns=100_000_000, robots=[spec_to_msg(spec)]
    )
    with path.open("wb") as f:
        rec = Recorder(f)
        rec.add(keys.info("s"), encode(info), 1)
        rec.add(keys.state("s"), _state(1), 2)
        reading = SensorReading(
            tick=1,
            sim_time_ns=100_000_000,
            robot_id=1,
            proximity_ids=[],
            proximity_m=[],
            proximity_legacy=[],
            compass_deg=0.0,
            gps=(1.0, 2.0, 0.0),
            lasers=[LaserScan(id=3, ranges=[1.5, None, 2.5])],
        )
        rec.add(keys.sensors("s", 1), encode(reading), 3)
        rec.finish()
    with path.open("rb") as f:
        [(schema, channel, m)] = [x for x in make_reader(f).iter_messages() if x[1].topic.startswith("/foxglove/laser")]
    assert channel.topic == "/foxglove/laser/1/3"
    assert schema.name == "foxglove.LaserScan"
    assert schema.encoding == "protobuf"
    scan = proto_decode(schema.data, schema.name, m.data)
    assert scan["frame_id"] == "robot1"
    assert scan["ranges"] == [1.5, "Infinity", 2.5]  # a beam that met nothing: no point drawn (range 0 drew one)
    assert scan["intensities"] == [1.0, 0.0, 1.0]
    assert (scan["start_angle"], scan["end_angle"]) == (-math.pi / 2, math.pi / 2)
    assert scan["pose"]["position"]["x"] == 0.2


def test_the_sim_time_index_has_a_state_a_simulated_second_and_the_last_state(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    _write(path, 25)  # states 0.1 s to 2.5 s apart by 0.1 s
    with path.open("rb") as f:
        meta = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    index = sorted((int(k), int(v)) for k, v in meta[SIM_INDEX].items())
    assert index == [(s, 1_000_000_000 + s) for s in (100_000_000, 1_100_000_000, 2_100_000_000, 2_500_000_000)]
