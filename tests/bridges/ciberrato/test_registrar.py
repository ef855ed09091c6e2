"""The registrar: legacy registration rules, and registrations asked of the world until it answers."""

from __future__ import annotations

from iw_zenoh.bridges.ciberrato.registrar import MAX_PENDING, WORLD_WAIT_S, Registrar
from iw_zenoh.bridges.ciberrato.registration import parse_registration

from iw_zenoh.core.params import SimParameters
from iw_zenoh.messages import RegisterReply, RegisterRequest, decode, encode
from tests.support.fakes import FakeBus

PEER = ("127.0.0.1", 40001)
ROBOT = b'<Robot Id="1" Name="bot1" />'


def _registrar(bus: FakeBus) -> Registrar:
    return Registrar(bus, "s", "ciberrato", SimParameters())


def test_a_viewer_is_served_at_once_and_nothing_is_asked() -> None:
    bus = FakeBus()
    adm = _registrar(bus).admit(parse_registration(b"<View/>"), PEER, None, (), 0.0)
    assert (adm.viewer, adm.refused, adm.params) == ("view", "", SimParameters())
    assert bus.asks == []


def test_a_body_out_of_range_is_refused_with_an_answer_and_its_reason() -> None:
    adm = _registrar(FakeBus()).admit(parse_registration(b'<Robot Name="x" Width="-1"/>'), PEER, None, (), 0.0)
    assert adm.answer
    assert "width" in adm.refused


def test_a_robot_is_asked_of_the_world_for_its_agent() -> None:
    bus = FakeBus()
    _registrar(bus).admit(parse_registration(ROBOT), PEER, None, (), 0.0)
    (key, payload, _), *_ = bus.asks
    assert key == "iw/s/world/register"
    req = decode(payload, RegisterRequest)
    assert (req.agent, req.spec.name, req.spec.id) == ("ciberrato", "bot1", 1)


def test_a_client_repeating_its_registration_is_not_asked_twice() -> None:
    bus = FakeBus()
    bus.answer = lambda key, payload: None  # in flight
    reg = _registrar(bus)
    reg.admit(parse_registration(ROBOT), PEER, None, (), 0.0)
    reg.admit(parse_registration(ROBOT), PEER, None, (), 0.1)
    assert len(bus.asks) == 1


def test_a_registration_no_world_answers_is_asked_again_until_one_does() -> None:
    bus = FakeBus()
    reg = _registrar(bus)
    reg.admit(parse_registration(ROBOT), PEER, None, (), 0.0)
    assert reg.answered(0.1) == []  # no queryable yet: not asked again at once
    assert len(bus.asks) == 1
    ok = RegisterReply(ok=True, robot_id=1)
    bus.answer = lambda key, payload: [encode(ok)]
    assert reg.answered(0.25) == []  # asked again; its answer is read on the next pass
    assert len(bus.asks) == 2
    [(peer, pending, reply)] = reg.answered(0.26)
    assert (peer, pending.spec.name, reply) == (PEER, "bot1", ok)
    assert reg.pending == {}


def test_a_registration_no_world_answers_in_time_ends_without_answer() -> None:
    reg = _registrar(FakeBus())
    reg.admit(parse_registration(ROBOT), PEER, None, (), 0.0)
    [(_, _, reply)] = reg.answered(WORLD_WAIT_S)
    assert reply is None


def test_an_answer_that_does_not_decode_counts_as_none() -> None:
    bus = FakeBus()
    bus.answer = lambda key, payload: [b"{not json"]
    reg = _registrar(bus)
    reg.admit(parse_registration(ROBOT), PEER, None, (), 0.0)
    [(_, _, reply)] = reg.answered(0.0)
    assert reply is None


def test_a_second_robot_beacon_is_refused_while_the_first_is_registering() -> None:
    bus = FakeBus()
    bus.answer = lambda key, payload: None
    reg = _registrar(bus)
    beacon = parse_registration(b'<RobotBeacon Name="b" Height="1" />')
    assert reg.admit(beacon, PEER, None, (), 0.0).refused == ""
    refused = reg.admit(beacon, ("127.0.0.1", 40002), None, (), 0.0).refused
    assert "beacon" in refused


def test_registrations_waiting_for_the_world_are_bounded() -> None:
    bus = FakeBus()
    bus.answer = lambda key, payload: None  # no world answers: every one stays in flight
    reg = _registrar(bus)
    for port in range(MAX_PENDING):
        assert not reg.admit(parse_registration(ROBOT), ("127.0.0.1", 20000 + port), None, (), 0.0).refused
    adm = reg.admit(parse_registration(ROBOT), ("127.0.0.1", 30000), None, (), 0.0)
    assert "waiting for the world's answer" in adm.refused
    assert adm.answer
    assert len(reg.pending) == MAX_PENDING
