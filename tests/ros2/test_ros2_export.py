"""``iwz export --ros2`` of a recording in two parts (a restarted recorder's) writes one rosbag2
bag that rosbags' own reader reads: every part's states and readings, as odom, tf, clock, scan and
range, each at its simulation time; a driver's inputs as sensor_msgs/Joy; refusals name the
problem."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader
from rosbags.rosbag2 import Reader

from iw_zenoh import keys
from iw_zenoh.messages import (
    DriveInput,
    LabMsg,
    LaserMsg,
    LaserScan,
    RobotSpecMsg,
    SensorReading,
    WorldInfo,
    WorldState,
    encode,
)
from iw_zenoh.messages.world import IrSensorMsg
from iw_zenoh.record.parts import PART_META, next_part
from iw_zenoh.record.reader import open_recording
from iw_zenoh.record.recording import Recorder
from iw_zenoh.record.ros2_export import export_ros2, main
from iw_zenoh.ros2 import types as t

T0 = 1_000_000_000
SPEC = RobotSpecMsg(
    name="c", id=1, lasers=[LaserMsg(id=0, fov_deg=90.0, beams=3, range_m=5.0)], ir_sensors=[IrSensorMsg(id=4)]
)


def _state(tick: int) -> bytes:
    return encode(
        WorldState(
            tick=tick,
            sim_time_ns=tick * 100_000_000,
            revision=1,
            ids=[1],
            x=[0.1 * tick],
            y=[2.0],
            heading=[0.5],
            collided=[False],
            rolled_left=[0.01],
            rolled_right=[0.02],
            speed=[0.15],
        )
    )


def _reading(tick: int) -> bytes:
    return encode(
        SensorReading(
            tick=tick,
            sim_time_ns=tick * 100_000_000,
            robot_id=1,
            proximity_ids=[4],
            proximity_m=[None if tick % 2 else 1.5],
            proximity_legacy=[0.0],
            compass_deg=0.0,
            gps=(0.0, 0.0, 0.0),
            lasers=[LaserScan(id=0, ranges=[1.0, None, 2.0])],
        )
    )


def _part(first: Path, ticks: range, run: str | None, drive: bool = False) -> None:
    path, part, user = next_part(first, run)
    with path.open("wb") as f:
        rec = Recorder(f, {PART_META: part, "iw.user": user or {"scenario": "unit"}}, chunk_size=1500, scene=False)
        info = WorldInfo(
            tick=0,
            sim_time_ns=0,
            revision=1,
            lab=LabMsg(name="l", width=10, height=10),
            period_ns=100_000_000,
            robots=[SPEC],
        )
        rec.add(keys.info("s"), encode(info), T0 + ticks[0] * 100_000_000 - 1)
        for k in ticks:
            at = T0 + k * 100_000_000
            rec.add(keys.state("s"), _state(k), at)
            rec.add(keys.sensors("s", 1), _reading(k), at + 1)
            if drive:  # a driver pushing forward and to the right, the dead-man held on even ticks
                d = DriveInput(robot_id=1, driver="page-1", seq=k, x=0.25, y=0.5, buttons=(k + 1) % 2 | 0b100)
                rec.add(keys.drive("s", 1), encode(d), at + 2)
        rec.finish()


def test_a_recording_in_two_parts_exports_to_one_bag_rosbags_reads(tmp_path: Path) -> None:
    first = tmp_path / "run.mcap"
    _part(first, range(1, 21), None)
    _part(first, range(21, 41), "")
    assert (tmp_path / "run.part2.mcap").exists()
    seen: list[float] = []
    counts = export_ros2(first, tmp_path / "bag", progress=seen.append)
    assert seen[-1] == 1.0
    want = {"/robot1/odom": 40, "/tf": 40, "/clock": 40, "/robot1/scan": 40, "/robot1/range/s4": 40}
    assert counts == want
    with Reader(tmp_path / "bag") as r:
        assert {c.topic: c.msgcount for c in r.connections} == want
        assert {c.topic: c.msgtype for c in r.connections}["/robot1/range/s4"] == t.RANGE
        odom = [c for c in r.connections if c.topic == "/robot1/odom"]
        poses = [(stamp, t.store().deserialize_cdr(d, t.ODOMETRY)) for _, stamp, d in r.messages(connections=odom)]
    assert [s for s, _ in poses] == [k * 100_000_000 for k in range(1, 41)]
    assert [o.pose.pose.position.x for _, o in poses] == [0.1 * k for k in range(1, 41)]
    o = poses[0][1]
    assert o.twist.twist.angular.z == pytest.approx((0.02 - 0.01) / SPEC.height_m / 0.1)


def test_refusals_name_the_problem(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "bag").mkdir()
    _part(tmp_path / "run.mcap", range(1, 3), None)
    assert main([str(tmp_path / "run.mcap"), "--ros2", "-o", str(tmp_path / "bag")]) == 2
    assert "exists" in capsys.readouterr().err
    (tmp_path / "junk.mcap").write_bytes(b"not mcap at all")
    assert main([str(tmp_path / "junk.mcap"), "--ros2", "-o", str(tmp_path / "bag2")]) == 2
    assert "junk.mcap" in capsys.readouterr().err
    assert not (tmp_path / "bag2").exists()


HOSTILE_DRIVES = [  # recorded on a drive key, none of them a driver's input: each skipped, the rest exported
    b'{"robot_id":1,"driver":"page-1","x":5.0}',  # a stick beyond -1..1
    b'{"robot_id":1,"driver":"","y":0.5}',  # no driver
    b'{"robot_id":1,"driver":"p","x":"left"}',  # a word for a number
    b'{"robot_id":1,"driver":"p","buttons":70000}',  # more than 16 buttons
    b'{"robot_id":1,"driver":"p","y":NaN}',  # not JSON
    '{"robot_id":1,"driver":"\u00e9\u00e9","x":1e999}'.encode(),  # non-ASCII, and infinity
    b"\xff\xfe" * 5000,  # not text at all, 10 kB
]


def test_a_drivers_inputs_export_as_joy_at_the_simulation_time_they_were_given(tmp_path: Path) -> None:
    _part(tmp_path / "run.mcap", range(1, 11), None, drive=True)
    counts = export_ros2(tmp_path / "run.mcap", tmp_path / "bag")
    assert counts["/robot1/joy"] == 10
    with Reader(tmp_path / "bag") as r:
        conns = [c for c in r.connections if c.topic == "/robot1/joy"]
        assert [c.msgtype for c in conns] == [t.JOY]
        joys = [(stamp, t.store().deserialize_cdr(d, t.JOY)) for _, stamp, d in r.messages(connections=conns)]
    assert [s for s, _ in joys] == [k * 100_000_000 for k in range(1, 11)]  # the state's time before each
    for k, (stamp, j) in zip(range(1, 11), joys, strict=True):
        assert (j.header.stamp.sec, j.header.stamp.nanosec) == divmod(stamp, 1_000_000_000)
        assert j.header.frame_id == "robot1/base_link"
        assert list(j.axes) == [-0.25, 0.5]  # ROS's axis 0 is positive to the left; ours, to the right
        assert list(j.buttons) == [(k + 1) % 2, 0, 1] + [0] * 13  # bit 0, the dead-man, first


def test_hostile_drive_payloads_in_a_recording_are_skipped_and_the_inputs_around_them_exported(tmp_path: Path) -> None:
    first = tmp_path / "run.mcap"
    _part(first, range(1, 11), None, drive=True)
    spoiled = tmp_path / "spoiled.mcap"
    with first.open("rb") as f, spoiled.open("wb") as out:  # the same run with the hostile ones between its inputs
        rec = Recorder(out, {"iw.user": {"scenario": "unit"}}, chunk_size=1500, scene=False)
        for _, channel, message in make_reader(f).iter_messages():
            rec.add(channel.topic, message.data, message.log_time)
            if channel.topic == keys.drive("s", 1) and message.sequence in (0, 5):  # every one, twice
                for k, junk in enumerate(HOSTILE_DRIVES):
                    rec.add(channel.topic, junk, message.log_time + 1 + k)
        rec.finish()
    with open_recording(spoiled) as r:  # they are there, and refused as no driver's input
        assert len(list(r.records(("drive",)))) == 10
        assert r.bad == {keys.drive("s", 1): 2 * len(HOSTILE_DRIVES)}
    counts = export_ros2(spoiled, tmp_path / "bag")
    assert counts == export_ros2(first, tmp_path / "bag2")  # not one input lost, not one invented
