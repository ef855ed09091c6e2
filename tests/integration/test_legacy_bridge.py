"""Unmodified legacy clients (written from the fact sheet) over real UDP, in a Zenoh world."""

from __future__ import annotations

import socket
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import msgspec
import numpy as np
import pytest
from lxml import etree

from iw_zenoh import keys
from iw_zenoh.bus import PendingQuery
from iw_zenoh.messages import (
    Event,
    Hear,
    RegisterReply,
    RegisterRequest,
    RobotSpecMsg,
    SensorReading,
    WorldState,
    decode,
    encode,
    encode_sensor_batch,
)
from tests.integration.harness import (
    MAPS,
    Net,
    iwz_run_argv,
    register,
    stop_run,
    subscribe,
    wait_alive,
    wait_event,
    wait_msg,
)
from tests.integration.legacy import LegacyClient, ciberrato_world, udp_port

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(150)]


def _c1_params(net: Net, old: str, new: str) -> Path:
    """C1's parameters file with one attribute changed (written in the test's folder)."""
    path = net.tmp / f"params-{len(list(net.tmp.glob('params-*')))}.xml"
    text = (MAPS / "ciberrato" / "C1-config.xml").read_text()
    assert old in text
    path.write_text(text.replace(old, new))
    return path


def test_a_robot_registering_before_the_world_is_up_is_accepted_when_it_comes(
    net: Net, clients: list[LegacyClient]
) -> None:
    # a legacy agent started with `iwz run` may ask before the world's queryable exists; it was
    # refused at once ("no world answered") where the legacy server would have answered it
    port = udp_port()
    net.spawn("bridge", "ciberrato", "--port", str(port))
    wait_alive(net.client(), keys.alive(net.sim, "bridge", "ciberrato"))  # its UDP port is open
    robot = LegacyClient(port)
    clients.append(robot)
    robot.sock.sendto(b'<Robot Id="1" Name="early"/>', robot.server)
    robot.sock.settimeout(1.0)
    with pytest.raises(TimeoutError):
        robot.recv()  # no refusal while no world is there to answer
    lab, grid = MAPS / "ciberrato" / "C1-lab.xml", MAPS / "ciberrato" / "C1-grid.xml"
    net.spawn("world", str(lab), "--grid", str(grid), "--profile", "ciberrato", "--period-ms", "50")
    robot.sock.settimeout(15.0)
    data, robot.server = robot.sock.recvfrom(1024)
    assert etree.fromstring(data[:-1]).get("Status") == "Ok"


def test_a_legacy_robot_registers_senses_and_drives(net: Net, clients: list[LegacyClient]) -> None:
    port = ciberrato_world(net)
    bus = net.client()
    states = subscribe(bus, keys.state(net.sim), maxlen=1)
    robot = LegacyClient(port)
    clients.append(robot)
    reply = robot.register(
        b'<Robot Id="1" Name="pyRob"><IRSensor Id="0" Angle="0.0" /><IRSensor Id="1" Angle="60.0" /><IRSensor Id="2" Angle="-60.0" /><IRSensor Id="3" Angle="180.0" /></Robot>'
    )
    assert reply.endswith(b"\n\x00")
    root = etree.fromstring(reply[:-1])
    assert root.get("Status") == "Ok"
    assert root[0].get("NBeacons") == "3"
    assert root[0].get("SimTime") == "5000"
    assert robot.server[1] != port  # answered from a socket of its own
    m = etree.fromstring(robot.recv()[:-1])
    assert m.tag == "Measures"
    assert int(m.get("Time")) >= 0
    assert len(m.find("Sensors").findall("IRSensor")) == 4
    assert m.find("Leds").get("EndLed") == "Off"
    assert m.find("Buttons") is not None
    first = wait_msg(states, WorldState, lambda s: 1 in s.ids)
    for _ in range(40):
        robot.send(b'<Actions LeftMotor="0.1" RightMotor="0.1"/>')
        robot.recv()
    moved = wait_msg(states, WorldState, lambda s: s.x[s.ids.index(1)] > first.x[first.ids.index(1)] + 0.3)
    assert moved.y[moved.ids.index(1)] == pytest.approx(11.0, abs=0.2)


def test_a_malformed_sensor_batch_is_reported_and_the_robot_still_served(net: Net, clients: list[LegacyClient]) -> None:
    port = ciberrato_world(net)
    bus = net.client()
    events = subscribe(bus, keys.all_events(net.sim))
    robot = LegacyClient(port)
    clients.append(robot)
    assert b'Status="Ok"' in robot.register(b'<Robot Id="1" Name="a"/>')
    robot.recv()
    key = keys.sensor_batch(net.sim, (1, 1))
    bus.publish(key, b'{"tick": "soon"}')
    ev = wait_event(events, "bad-message", timeout_s=10)
    assert ev.key == key
    assert "iw.SensorBatch/1" in ev.reason
    before = int(etree.fromstring(robot.recv()[:-1]).get("Time"))
    assert int(etree.fromstring(robot.recv()[:-1]).get("Time")) > before  # still served, cycle by cycle


def test_a_legacy_viewer_gets_the_lab_grid_and_robot_states(net: Net, clients: list[LegacyClient]) -> None:
    port = ciberrato_world(net)
    robot = LegacyClient(port)
    clients.append(robot)
    robot.register(b'<Robot Name="cRob" Id="1"></Robot>\x00')
    viewer = LegacyClient(port)
    clients.append(viewer)
    reply = viewer.register(b"<View/>\n\x00")
    assert etree.fromstring(reply[:-1]).get("Status") == "Ok"
    viewer.send(b"<LabReq/>\x00")
    viewer.send(b"<GridReq/>\x00")
    got: dict[str, bytes] = {}
    deadline = time.monotonic() + 20
    while len(got) < 3 and time.monotonic() < deadline:
        data = viewer.recv(65536)  # the Qt viewer reads whole datagrams (a C1 lab is ~6 kB)
        got.setdefault(etree.fromstring(data.split(b"\x00")[0]).tag, data)
    assert got["Lab"].startswith(b'<Lab Name="RMI-2122 C1 Lab" Height="14" Width="28"')
    assert len(etree.fromstring(got["Lab"][:-1]).findall("Wall")) == 45
    assert b'<Position X="3" Y="11" Dir="0"/>' in got["Grid"]
    assert etree.fromstring(got["Robot"][:-1]).get("Name") == "cRob"


def test_bad_datagrams_are_refused_and_never_stall_a_good_client(net: Net, clients: list[LegacyClient]) -> None:
    port = ciberrato_world(net)
    bus = net.client()
    events = subscribe(bus, keys.event(net.sim, "legacy-refused"))
    robot = LegacyClient(port)
    clients.append(robot)
    robot.register(b'<Robot Name="good" Id="1"/>')
    robot.recv()
    bad = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    for junk in (
        b"<Robot",
        b"<Hack/>",
        b"\xff\xfe",
        b'<!DOCTYPE x [<!ENTITY a "b">]><Robot Name="&a;"/>',
        b"<View/>" + b" " * 2000,
    ):
        bad.sendto(junk, ("127.0.0.1", port))
    robot.send(b"<Actions><Teleport/></Actions>")
    ev = wait_msg(events, Event, timeout_s=10)
    assert ev.data["peer"].startswith("127.0.0.1:")
    for _ in range(5):  # the good client is still served every cycle
        assert etree.fromstring(robot.recv()[:-1]).tag == "Measures"
    dup = LegacyClient(port)
    clients.append(dup)
    dup.register(b'<Robot Name="again" Id="1"/>')  # id 1 is taken: refused
    bad.close()


def test_iwz_run_a_ciberrato_scenario_serves_legacy_clients(tmp_path: Path, clients: list[LegacyClient]) -> None:
    port = udp_port()
    text = (
        (MAPS / "scenarios" / "ciberrato-c1.toml")
        .read_text()
        .replace("port = 6000", f"port = {port}")
        .replace("duration_s = 250", "duration_s = 6")
    )
    text = text.replace('"../ciberrato/', f'"{MAPS}/ciberrato/')
    sc = tmp_path / "c1.toml"
    sc.write_text(text)
    argv = iwz_run_argv(sc, tmp_path, "c1")
    run = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        robot = LegacyClient(port)
        clients.append(robot)
        reply = robot.register(b'<Robot Id="1" Name="student"/>', tries=60)
        assert etree.fromstring(reply[:-1]).get("Status") == "Ok"
        times = [int(etree.fromstring(robot.recv()[:-1]).get("Time")) for _ in range(10)]
        assert times == sorted(times)
        out, _ = run.communicate(timeout=90)
    finally:
        if run.poll() is None:
            stop_run(run)  # after a failed assertion: the launcher and everything it started
    assert run.returncode == 0, out
    assert "ended at t=6.0 s" in out


OPEN_LAB = '<Lab Name="open" Width="28" Height="14"/>'
TWO = '<Grid><Position X="5" Y="7" Dir="0"/><Position X="7.2" Y="7" Dir="180"/></Grid>'


def test_a_legacy_robot_and_a_native_one_see_hear_and_hit_each_other(net: Net, clients: list[LegacyClient]) -> None:
    port = ciberrato_world(net, None, lab=OPEN_LAB, grid=TWO, radio=True)
    bus = net.client()
    events = subscribe(bus, keys.event(net.sim, "collision"))
    robot = LegacyClient(port)
    clients.append(robot)
    robot.register(b'<Robot Id="1" Name="legacy"/>')
    native = register(bus, net.sim, RobotSpecMsg(name="native", id=2, shape="circle"))
    assert native.ok, native.reason
    native_sensors = subscribe(bus, keys.sensors(net.sim, 2))
    native_hear = subscribe(bus, keys.hear(net.sim, 2))
    # the native robot sees the legacy one 1.2 m ahead (rims 0.5 m from the centres)
    seen = wait_msg(native_sensors, SensorReading, lambda r: r.proximity_m[0] is not None)
    assert seen.proximity_m[0] == pytest.approx(1.2, abs=0.25)
    # and the legacy robot sees the native one: IR 0 reads about 1/1.2 (once it is there)
    values = [
        float(etree.fromstring(robot.recv()[:-1]).find("Sensors").find("IRSensor").get("Value")) for _ in range(20)
    ]
    assert values[-1] == pytest.approx(1 / 1.2, abs=0.35)
    robot.send(b"<Actions><Say><![CDATA[hello native]]></Say></Actions>")
    heard = wait_msg(native_hear, Hear, lambda h: any(x.sender == 1 for x in h.messages))
    assert heard.messages[0].text == "hello native"
    for _ in range(60):  # drive into it
        robot.send(b'<Actions LeftMotor="0.15" RightMotor="0.15"/>')
        robot.recv()
    hit = wait_msg(events, Event, lambda e: e.robot_id == 1, timeout_s=20)
    assert hit.data["robots"] == [2]


def test_thousands_of_malformed_datagrams_leave_good_clients_served(net: Net, clients: list[LegacyClient]) -> None:
    port = ciberrato_world(net)
    robot = LegacyClient(port)
    clients.append(robot)
    robot.register(b'<Robot Name="good" Id="1"/>')
    good = [
        b'<Robot Id="1" Name="pyRob"><IRSensor Id="0" Angle="0.0" /></Robot>',
        b'<Actions LeftMotor="0.1" RightMotor="0.1"/>',
        b"<Actions><Say><![CDATA[hi]]></Say></Actions>\n\x00",
        b"<View/>\n\x00",
        b'<Robot Id="3" Removed="Yes"/>\x00',
    ]
    rng = np.random.default_rng(7)
    fuzz = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sent = 0
        for i in range(3000):
            base = bytearray(good[i % len(good)])
            kind = i % 4
            if kind == 0:  # truncate
                data = bytes(base[: rng.integers(0, len(base))])
            elif kind == 1:  # flip bytes
                for _ in range(3):
                    base[rng.integers(0, len(base))] = rng.integers(0, 256)
                data = bytes(base)
            elif kind == 2:  # noise
                data = rng.integers(0, 256, rng.integers(1, 200), dtype=np.uint8).tobytes()
            else:  # oversized
                data = bytes(base) + b" " * int(rng.integers(1024, 3000))
            fuzz.sendto(data, ("127.0.0.1", port))
            sent += 1
            if i % 300 == 0:  # all the while, the good client is served every cycle
                assert etree.fromstring(robot.recv()[:-1]).tag == "Measures"
        assert sent == 3000
        for _ in range(10):
            assert etree.fromstring(robot.recv()[:-1]).tag == "Measures"
    finally:
        fuzz.close()


def test_requestable_sensors_the_request_limit_and_the_gps_origin(net: Net, clients: list[LegacyClient]) -> None:
    params = net.tmp / "params.xml"
    params.write_text(
        '<Parameters GPS="On" GPSLinNoise="0" ObstacleRequestable="On" NRequestsPerCycle="1" CompassSensor="On" CompassNoise="0"/>'
    )
    port = ciberrato_world(net, params)
    robot = LegacyClient(port)
    clients.append(robot)
    reply = etree.fromstring(robot.register(b'<Robot Id="1" Name="req"/>')[:-1])
    assert reply[0].get("ObstacleRequestable") == "On"
    unasked = [etree.fromstring(robot.recv()[:-1]) for _ in range(5)][-1]
    assert unasked.find("Sensors").findall("IRSensor") == []  # requestable and not requested: not sent
    gps = unasked.find("Sensors").find("GPS")
    assert (float(gps.get("X")), float(gps.get("Y"))) == (843.2, 405.4)  # (3, 11) from the legacy origin
    got: list[list[str]] = []
    for _ in range(10):
        robot.send(b'<Actions><SensorRequests IRSensor0="Yes" IRSensor2="Yes"/></Actions>')
        m = etree.fromstring(robot.recv()[:-1])
        got.append([ir.get("Id") for ir in m.find("Sensors").findall("IRSensor")])
    assert ["0"] in got  # one request a cycle honoured: the first
    assert all(ids in ([], ["0"]) for ids in got)


def _recv_until(client: LegacyClient, pred: Callable[[etree._Element], bool], tries: int = 200) -> etree._Element:
    for _ in range(tries):
        data = client.recv(65536)
        el = etree.fromstring(data[:-1])
        if pred(el):
            return el
    raise AssertionError("never saw the expected datagram")


def _robot_and_viewer(port: int, clients: list[LegacyClient], robot_xml: bytes) -> tuple[LegacyClient, LegacyClient]:
    """A registered legacy robot and a registered viewer (both stopped by the fixture)."""
    robot = LegacyClient(port)
    clients.append(robot)
    robot.register(robot_xml)
    viewer = LegacyClient(port)
    clients.append(viewer)
    viewer.register(b"<View/>\n\x00")
    return robot, viewer


def test_end_led_finishes_a_legacy_robot_for_good(net: Net, clients: list[LegacyClient]) -> None:
    port = ciberrato_world(net)
    bus = net.client()
    states = subscribe(bus, keys.state(net.sim), maxlen=1)
    robot, viewer = _robot_and_viewer(port, clients, b'<Robot Id="1" Name="done"/>')
    robot.recv()
    robot.send(b'<Actions LeftMotor="0.0" RightMotor="0.0" EndLed="On"/>')
    for _ in range(30):  # whatever it asks afterwards, it does not move
        robot.send(b'<Actions LeftMotor="0.15" RightMotor="0.15"/>')
        m = etree.fromstring(robot.recv()[:-1])
    assert m.find("Leds").get("EndLed") == "On"
    a = wait_msg(states, WorldState, lambda s: 1 in s.ids)
    b = wait_msg(states, WorldState, lambda s: s.tick >= a.tick + 10)
    assert b.x[b.ids.index(1)] == pytest.approx(a.x[a.ids.index(1)], abs=1e-6)
    finished = _recv_until(viewer, lambda el: el.tag == "Robot" and el.get("State") == "Finished", tries=40)
    assert finished.get("State") == "Finished"


def test_scores_and_states_follow_the_legacy_game(net: Net, clients: list[LegacyClient]) -> None:
    params = _c1_params(net, 'ScoreSensor="Off"', 'ScoreSensor="On"')
    port = ciberrato_world(
        net,
        params,
        lab='<Lab Name="home" Width="28" Height="14"><Target X="5" Y="7" Radius="1"/></Lab>',
        grid='<Grid><Position X="5" Y="7" Dir="0"/></Grid>',
        bridge=("--scoring", "0"),
    )
    robot, viewer = _robot_and_viewer(port, clients, b'<Robot Id="1" Name="home"/>')
    # competitive: the penalty starts at 100 + 100 per target; a visit at the start takes 100 off
    robot.send(b'<Actions LeftMotor="0" RightMotor="0" VisitingLed="On"/>')
    m = _recv_until(
        robot, lambda el: el.find("Sensors/Score") is not None and el.find("Sensors/Score").get("VisitedMask") == "1"
    )
    assert m.find("Sensors/Score").get("Score") == "200"  # 100 + pen, pen = 200 - 100
    # home (a target), every target visited: ReturningLed starts the return
    robot.send(b'<Actions LeftMotor="0" RightMotor="0" VisitingLed="Off" ReturningLed="On"/>')
    st = _recv_until(viewer, lambda el: el.tag == "Robot" and el.get("State") == "Returning")
    assert st.get("VisitedMask") == "1"
    robot.send(b'<Actions LeftMotor="0" RightMotor="0" EndLed="On"/>')
    _recv_until(viewer, lambda el: el.tag == "Robot" and el.get("State") == "Finished")


def _reading(robot_id: int, tick: int) -> bytes:
    r = SensorReading(
        tick=tick,
        robot_id=robot_id,
        proximity_ids=[0, 1, 2, 3],
        proximity_m=[None] * 4,
        proximity_legacy=[0.5] * 4,
        compass_deg=10.0,
        gps=(1.0, 2.0, 0.0),
    )
    return encode(r)


def test_a_registration_the_world_is_slow_to_answer_stalls_no_other_client(
    net: Net, clients: list[LegacyClient]
) -> None:
    # the test plays the world: it answers registrations when it chooses and sends readings
    bus = net.client()
    registrations = bus.serve(keys.register(net.sim))
    port = udp_port()
    net.spawn("bridge", "ciberrato", "--port", str(port))

    def ask(c: LegacyClient, xml: bytes, timeout_s: float = 30.0) -> PendingQuery:
        """Registers (again every half second, as croblink would while the bridge starts) until
        the bridge asks the world."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            c.sock.sendto(xml, c.server)
            again = time.monotonic() + 0.5
            while time.monotonic() < again:
                got = registrations.poll()
                if got:
                    return got[0]
                time.sleep(0.01)  # polling the test's own queryable: there is no event to wait on
        raise AssertionError("the bridge asked the world nothing")

    def accept(q: PendingQuery, robot_id: int) -> None:
        req = decode(q.payload, RegisterRequest)
        spec = RobotSpecMsg(**{**msgspec.structs.asdict(req.spec), "id": robot_id, "x_m": 2.0, "y_m": 2.0 * robot_id})
        q.reply(encode(RegisterReply(ok=True, robot_id=robot_id, spec=spec)))

    a = LegacyClient(port)
    clients.append(a)
    accept(ask(a, b'<Robot Id="1" Name="a"/>'), 1)
    reply, a.server = a.sock.recvfrom(1024)
    assert reply.startswith(b'<Reply Status="Ok"')
    b = LegacyClient(port)
    clients.append(b)
    slow = ask(b, b'<Robot Id="2" Name="b"/>')  # asked, and left unanswered for now
    a.sock.settimeout(1.0)
    for tick in (5, 6, 7):  # robot a's readings keep coming and so do its Measures
        batch = encode_sensor_batch(tick, tick * 50_000_000, "1-1", [_reading(1, tick)], 0, [1])
        bus.publish(keys.sensor_batch(net.sim, (1, 1)), batch)
        assert a.recv().startswith(f'<Measures Time="{tick}"'.encode())
    accept(slow, 2)
    reply, _ = b.sock.recvfrom(1024)
    assert reply.startswith(b'<Reply Status="Ok"')


def test_a_robot_beacon_moves_with_its_robot_and_only_one_beacon_is_allowed(
    net: Net, clients: list[LegacyClient]
) -> None:
    params = _c1_params(net, 'BeaconSensor="Off"', 'BeaconSensor="On"')
    port = ciberrato_world(
        net,
        params,
        lab='<Lab Name="open" Width="20" Height="10"></Lab>',
        grid='<Grid><Position X="3" Y="2" Dir="0"/><Position X="10" Y="5" Dir="0"/><Position X="3" Y="8" Dir="0"/></Grid>',
    )
    early, carrier, second, late = (LegacyClient(port) for _ in range(4))
    clients += [early, carrier, second, late]
    assert b'NBeacons="0"' in early.register(b'<Robot Id="1" Name="early"/>')
    assert b'Status="Ok"' in carrier.register(b'<RobotBeacon Name="B" Id="2" Height="4"/>\x00')
    # the legacy rule: a RobotBeacon is refused once the lab has a beacon (the first one is it)
    assert b'Status="Refused"' in second.register(b'<RobotBeacon Name="C" Id="3" Height="4"/>\x00')
    reply = late.register(b'<Robot Id="3" Name="late"/>')
    assert b'NBeacons="0"' in reply  # the reply's count leaves it out, as the legacy server's did

    def beacon(c: LegacyClient) -> str | None:
        for _ in range(60):
            sensors = etree.fromstring(c.recv()[:-1]).find("Sensors")
            got = sensors.find("BeaconSensor") if sensors is not None else None
            if got is not None and got.get("Value") != "NotVisible":
                return str(got.get("Value"))
        return None

    # the late robot at (3, 8) heading east sees the carrier at (10, 5): atan2(-3, 7) = -23 degrees
    value = beacon(late)
    assert value is not None
    assert float(value) == pytest.approx(-23.2, abs=8.0)
    # it moves with its robot: the carrier drives east, so its bearing from (3, 8) nears 0
    for _ in range(40):
        carrier.send(b'<Actions LeftMotor="0.1" RightMotor="0.1"/>')
        carrier.recv()
    # the late robot's socket still holds the messages of the cycles it did not read (from
    # before the carrier moved): read on until the bearing shows the move, a bounded number of times
    moved = beacon(late)
    for _ in range(10):
        if moved is not None and float(moved) > float(value) + 3.0:
            break
        moved = beacon(late)
    assert moved is not None
    assert float(moved) > float(value) + 3.0
    # a robot registered before the beacon has no sensor for it
    m = etree.fromstring(early.recv()[:-1])
    assert m.find("Sensors") is None or m.find("Sensors").find("BeaconSensor") is None


def test_the_simulation_finishes_at_sim_time_and_stays_finished(net: Net, clients: list[LegacyClient]) -> None:
    params = _c1_params(net, 'SimTime="5000"', 'SimTime="40"')
    port = ciberrato_world(net, params)
    bus = net.client()
    events = subscribe(bus, keys.event(net.sim, "legacy-finished"))
    robot, viewer = _robot_and_viewer(port, clients, b'<Robot Id="1" Name="late"/>')

    def measures() -> tuple[int, str, str]:
        m = etree.fromstring(robot.recv()[:-1])
        b = m.find("Buttons")
        return int(m.get("Time")), b.get("Start"), b.get("Stop")

    for _ in range(200):  # drive until the Time limit
        robot.send(b'<Actions LeftMotor="0.1" RightMotor="0.1"/>')
        if measures()[0] >= 40:
            break
    wait_msg(events, Event, timeout_s=10)
    later = [measures() for _ in range(8)]  # still sent every cycle...
    assert later[-1] == (40, "Off", "Off")  # ...with Time frozen and both buttons Off
    viewer.send(b"<Start/>\n\x00")  # Finished is terminal: Start is ignored
    after = [measures() for _ in range(8)]
    assert all(m == (40, "Off", "Off") for m in after)
