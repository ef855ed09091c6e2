"""A chair with a laser scanner in a real run: the sensors process sends its scans, and the
recording holds them as ``foxglove.LaserScan``. Real processes, real router, a real file."""

from __future__ import annotations

import signal

import pytest
from mcap.reader import make_reader

from iw_zenoh import keys
from iw_zenoh.convert import spec_to_msg
from iw_zenoh.core.spec import LaserSpec, RobotSpec, SensorNoise
from iw_zenoh.messages import SensorReading
from tests.integration.harness import Net, register, subscribe, wait_alive, wait_msg
from tests.support.consumer import proto_decode

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(120)]

LAB = """<Lab Name="scan" Width="20" Height="10">
  <Wall Height="1.0"><Corner X="15" Y="1"/><Corner X="16" Y="1"/><Corner X="16" Y="9"/><Corner X="15" Y="9"/></Wall>
</Lab>"""
SCANNER = LaserSpec(0, 0.0, 0.0, 0.0, 180.0, 9, 12.0)  # beams every 22.5 degrees, the middle one ahead


def test_a_chair_with_a_scanner_gets_scans_and_the_recording_draws_them(net: Net) -> None:
    (net.tmp / "lab.xml").write_text(LAB)
    out = net.tmp / "run.mcap"
    bus = net.client()
    rec = net.spawn("record", "-o", str(out), "--quiet")
    wait_alive(bus, keys.alive(net.sim, "recorder", "recorder"))
    net.spawn("world", str(net.tmp / "lab.xml"))
    net.spawn("collision")
    net.spawn("sensors")
    spec = RobotSpec("scanner", x_m=5.0, y_m=5.0, dir_deg=0.0, noise=SensorNoise.off(), lasers=(SCANNER,))
    reply = register(bus, net.sim, spec_to_msg(spec))
    assert reply.ok, reply.reason
    readings = subscribe(bus, keys.sensors(net.sim, reply.robot_id))
    got = wait_msg(readings, SensorReading, lambda r: isinstance(r.lasers, list), timeout_s=60)
    assert isinstance(got.lasers, list)
    [scan] = got.lasers
    assert scan.id == 0
    assert len(scan.ranges) == 9
    assert scan.ranges[4] == pytest.approx(10.0)  # the wall's face at x = 15, straight ahead
    assert scan.ranges[0] == pytest.approx(5.0)  # the border at y = 0, to the right
    assert scan.ranges[8] == pytest.approx(5.0)  # and at y = 10, to the left
    wait_msg(readings, SensorReading, lambda r: r.tick > got.tick + 5, timeout_s=30)  # the recorder has them too
    rec.popen.send_signal(signal.SIGINT)  # it finishes its file (what it still holds first)
    assert rec.popen.wait(60) == 0, rec.output()
    with out.open("rb") as f:
        scans = [(s, c, m) for s, c, m in make_reader(f).iter_messages() if c.topic.startswith("/foxglove/laser")]
    assert scans, "no foxglove.LaserScan in the recording"
    assert {c.topic for _, c, _ in scans} == {f"/foxglove/laser/{reply.robot_id}/0"}
    assert {s.name for s, _, _ in scans} == {"foxglove.LaserScan"}
    schema, _channel, message = scans[-1]
    last = proto_decode(schema.data, schema.name, message.data)  # Foxglove's own type, in protobuf
    assert last["frame_id"] == f"robot{reply.robot_id}"
    assert last["ranges"][4] == pytest.approx(10.0)
