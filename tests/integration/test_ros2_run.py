"""The ros2-demo scenario in a real ``iwz run``, recorded; a ROS 2 teleop's Twist drives its chair;
then ``iwz export --ros2`` of that recording is read back by rosbags' rosbag2 reader (an
implementation we did not write): its topics, types and counts are the recording's, and its poses
are the recorded ones."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import zenoh
from rosbags.rosbag2 import Reader

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.bus.net import NetConfig
from iw_zenoh.messages import SensorReading, WorldState
from iw_zenoh.record.reader import open_recording
from iw_zenoh.ros2 import types as t
from tests.integration.harness import MAPS, iwz_run_argv, stop_run

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(240)]

TWIST_KEY = keys.ros2_topic(0, "/robot1/cmd_vel", t.dds_name(t.TWIST), t.type_hash(t.TWIST))


def _twist(v: float) -> bytes:
    st = t.store()
    v3 = st.types["geometry_msgs/msg/Vector3"]
    return bytes(st.serialize_cdr(st.types[t.TWIST](linear=v3(v, 0.0, 0.0), angular=v3(0.0, 0.0, 0.0)), t.TWIST))


def test_the_ros2_demo_is_driven_and_its_recording_exports_to_a_bag_rosbags_reads(tmp_path: Path) -> None:
    rec = tmp_path / "run.mcap"
    argv = iwz_run_argv(MAPS / "scenarios" / "ros2-demo.toml", tmp_path, "r2", record=rec)
    port = argv[argv.index("--port") + 1]
    run = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    bus: ZenohBus | None = None
    try:
        deadline = time.monotonic() + 60
        while bus is None:  # the launcher's router comes up first; polling its port has no event
            try:
                bus = ZenohBus(NetConfig(connect=(f"tcp/127.0.0.1:{port}",)))
            except Exception:
                assert run.poll() is None, run.communicate()
                assert time.monotonic() < deadline, "the run's router did not come up in 60 s"
                time.sleep(0.2)
        odom_seen = threading.Event()
        xs: list[float] = []

        def on_odom(s: zenoh.Sample) -> None:
            xs.append(t.store().deserialize_cdr(s.payload.to_bytes(), t.ODOMETRY).pose.pose.position.x)
            odom_seen.set()

        odom_key = keys.ros2_topic(0, "/robot1/odom", t.dds_name(t.ODOMETRY), t.type_hash(t.ODOMETRY))
        bus.session.declare_subscriber(odom_key, on_odom)
        assert odom_seen.wait(90), f"no odom from the demo in 90 s: {run.poll()}"
        pub = bus.session.declare_publisher(TWIST_KEY)
        x0 = xs[-1]
        end = time.monotonic() + 60
        while xs[-1] < x0 + 0.3:  # a teleop's 10 Hz until the chair has gone 0.3 m
            assert time.monotonic() < end, "the demo's chair did not move in 60 s"
            pub.put(_twist(0.4))
            time.sleep(0.1)  # the command rate itself, not a synchronisation
    finally:
        if bus is not None:
            bus.close()
        out, err = stop_run(run)
    assert rec.exists(), out + err

    bag = tmp_path / "bag"
    done = subprocess.run(
        [sys.executable, "-m", "iw_zenoh.cli", "export", "--ros2", str(rec), "-o", str(bag)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "100%" in done.stderr
    assert (bag / "metadata.yaml").exists()

    states: list[WorldState] = []
    scans = 0
    with open_recording(rec) as r:
        for m in r.records(("state", "sensors")):
            if isinstance(m.message, WorldState):
                states.append(m.message)
            elif (
                isinstance(m.message, SensorReading) and m.message.robot_id == 1 and isinstance(m.message.lasers, list)
            ):
                scans += 1
    with Reader(bag) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert {k: types[k] for k in ("/robot1/odom", "/robot1/scan", "/tf", "/clock")} == {
            "/robot1/odom": t.ODOMETRY,
            "/robot1/scan": t.LASER_SCAN,
            "/tf": t.TF_MESSAGE,
            "/clock": t.CLOCK,
        }
        with_chair = [s for s in states if 1 in s.ids]
        assert counts["/clock"] == len(states)
        assert counts["/robot1/odom"] == counts["/tf"] == len(with_chair) > 10
        assert counts["/robot1/scan"] == scans > 10
        by_time = {s.sim_time_ns: s for s in with_chair}
        odom = [c for c in reader.connections if c.topic == "/robot1/odom"]
        compared = 0
        for _conn, stamp, data in reader.messages(connections=odom):
            o = t.store().deserialize_cdr(data, t.ODOMETRY)
            s = by_time[stamp]
            i = s.ids.index(1)
            assert (o.pose.pose.position.x, o.pose.pose.position.y) == (s.x[i], s.y[i])
            compared += 1
        assert compared == len(with_chair)
        assert max(s.x[s.ids.index(1)] for s in with_chair) > min(s.x[s.ids.index(1)] for s in with_chair) + 0.3
