"""The bridge node's wiring with its sockets given as fakes: registration, actions out, Measures
in, refusals (the same over real UDP: tests/integration/test_legacy_bridge.py)."""

from __future__ import annotations

from iw_zenoh.bridges.ciberrato.node import Bridge

from iw_zenoh import keys
from iw_zenoh.messages import (
    ActionBatch,
    Event,
    LabMsg,
    RegisterReply,
    RobotSpecMsg,
    SensorBatch,
    SensorReading,
    WorldInfo,
    decode,
    encode,
)
from tests.support.captures import read
from tests.support.fakes import FakeBus, FakeTransport, Rig, Transports

PEER = ("127.0.0.1", 40001)
REFUSAL = next(g.data for g in read("nbots_refused_C1.txt") if g.data.startswith(b'<Reply Status="Refused"'))


def _events(bus: FakeBus, kind: str) -> list[Event]:
    return [decode(d, Event) for k, d in bus.published if k == keys.event("s", kind)]


def _register(bridge: Bridge, reception: FakeTransport, made: Transports) -> FakeTransport:
    reception.deliver(b'<Robot Id="7" Name="bot1" />', PEER)
    bridge.poll(0)
    return made.made[-1]


def test_a_robot_the_world_accepts_is_answered_from_a_socket_of_its_own(rig: Rig) -> None:
    bridge, _, reception, made = rig
    own = _register(bridge, reception, made)
    [(reply, to)] = own.sent
    assert to == PEER
    assert reply.startswith(b'<Reply Status="Ok">')
    assert reception.sent == []
    assert bridge.robots[7].start == (1.0, 2.0)


def test_a_robot_that_asks_before_the_worlds_description_is_told_the_world_that_answers(rig: Rig) -> None:
    # the world's queryables come up one by one: the registration may be answered by a world
    # whose description the bridge has not had yet (it told the robot 0 beacons, 50 ms cycles)
    bridge, bus, reception, made = rig
    accept = encode(RegisterReply(ok=True, robot_id=7, spec=RobotSpecMsg(name="bot1", id=7, x_m=1.0, y_m=2.0)))
    beacons = [(1.0, 1.0, 2.0), (2.0, 2.0, 2.0), (3.0, 3.0, 2.0)]
    info = WorldInfo(revision=1, lab=LabMsg(name="l", width=28, height=14, beacons=beacons), period_ns=75_000_000)

    def answer(key: str, payload: bytes) -> list[bytes]:
        bus.info.append(encode(info))  # described only once it has answered
        return [accept]

    bus.answer = answer
    own = _register(bridge, reception, made)
    [(reply, _)] = own.sent
    assert b'NBeacons="3"' in reply
    assert b'CycleTime="75"' in reply
    assert bridge.robots[7].n_beacons == 3


def test_a_robot_the_world_refuses_gets_the_legacy_refusal(rig: Rig) -> None:
    bridge, bus, reception, made = rig
    bus.answer = lambda key, payload: [encode(RegisterReply(ok=False, reason="no grid position left"))]
    own = _register(bridge, reception, made)
    assert own.sent == [(REFUSAL, PEER)]
    assert own.closed
    assert "no grid position left" in _events(bus, "legacy-refused")[0].reason


def test_actions_go_out_in_one_batch_of_the_bridges_agent(rig: Rig) -> None:
    bridge, bus, reception, made = rig
    own = _register(bridge, reception, made)
    own.deliver(b'<Actions LeftMotor="0.1" RightMotor="0.05" VisitingLed="On"/>', PEER)
    bridge.poll(0)
    [batch] = [decode(d, ActionBatch) for k, d in bus.published if k == keys.agent_actions("s", "ciberrato")]
    [act] = batch.actions
    assert (act.robot_id, act.left, act.right, act.visiting_led) == (7, 0.1, 0.05, True)


def test_readings_of_a_tick_become_the_robots_measures(rig: Rig) -> None:
    bridge, bus, reception, made = rig
    own = _register(bridge, reception, made)
    reading = SensorReading(
        tick=3,
        robot_id=7,
        proximity_ids=[0, 1, 2, 3],
        proximity_m=[None] * 4,
        proximity_legacy=[0.5, 2.1, 2.2, 0.6],
        compass_deg=0.0,
        gps=(0.0, 0.0, 0.0),
        ground=0,
    )
    batch = SensorBatch(tick=3, shard="0", readings=[reading], ids=[7])
    bus.queue(keys.all_sensor_batches("s")).put(keys.sensor_batch("s", (1, 1)), encode(batch))
    bridge.poll(0)
    measures, to = own.sent[-1]
    assert to == PEER
    assert measures.startswith(b'<Measures Time="3">')
    assert b'<IRSensor Id="1" Value="2.1"/>' in measures


def test_a_datagram_from_another_address_on_a_robots_socket_is_refused(rig: Rig) -> None:
    bridge, bus, reception, made = rig
    own = _register(bridge, reception, made)
    own.deliver(b'<Actions LeftMotor="0.1" RightMotor="0.1"/>', ("127.0.0.1", 40999))
    bridge.poll(0)
    assert not any(k == keys.agent_actions("s", "ciberrato") for k, _ in bus.published)
    assert _events(bus, "legacy-refused")


def test_a_second_registration_from_a_registered_address_is_refused(rig: Rig) -> None:
    bridge, _, reception, made = rig
    _register(bridge, reception, made)
    reception.deliver(b'<Robot Id="8" Name="again" />', PEER)
    bridge.poll(0)
    assert reception.sent == [(REFUSAL, PEER)]


def test_a_registration_that_does_not_parse_is_not_answered(rig: Rig) -> None:
    bridge, bus, reception, made = rig
    reception.deliver(b"<Robot", PEER)
    bridge.poll(0)
    assert reception.sent == []
    assert made.made == []
    assert _events(bus, "legacy-refused")


def test_a_viewer_gets_the_reply_from_its_own_socket(rig: Rig) -> None:
    bridge, bus, reception, made = rig
    reception.deliver(b"<View/>\n\x00", PEER)
    bridge.poll(0)
    [(reply, to)] = made.made[-1].sent
    assert (reply[:19], to) == (b'<Reply Status="Ok">', PEER)
    assert bus.asks == []
