"""The tick window: a message from too far ahead of the world is refused with its reason, and
the receiver keeps listening to the real ticks (one forged tick of 10^15 deafened an agent)."""

from __future__ import annotations

from dataclasses import dataclass, field

import msgspec
import pytest

from iw_zenoh import keys
from iw_zenoh.agent import HEARD_KEPT, AgentHost, RegistrationRefused
from iw_zenoh.agent.hosting import Command
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import (
    Actions,
    Event,
    Hear,
    Heard,
    RadioBatch,
    RegisterReply,
    RobotSpecMsg,
    SensorReading,
    decode,
    encode,
)
from iw_zenoh.ticks import MAX_TICKS_PER_S, WINDOW_TICKS, TickWindow, ViewWindow, too_far_ahead
from tests.support.builders import agent_host, world_state
from tests.support.fakes import FakeBus

S = 1_000_000_000


def test_a_tick_within_the_window_is_taken_and_one_beyond_it_refused_naming_both() -> None:
    assert too_far_ahead(10 + WINDOW_TICKS, 10) == ""
    why = too_far_ahead(10**15, 10)
    assert "tick 1000000000000000" in why
    assert "world's tick 10" in why
    assert f"at most {WINDOW_TICKS}" in why


def test_the_window_follows_the_ticks_it_accepts_and_never_a_refused_one() -> None:
    w = TickWindow()
    assert w.refuse(7, 0) == ""  # nothing known yet: the first tick is taken
    assert w.refuse(8, 0) == ""
    assert w.refuse(10**15, 0) != ""
    assert w.newest == 8
    assert w.refuse(9, 0) == ""  # the real ticks go on being heard
    assert w.refuse(3, 0) == ""  # a late tick is not refused (receivers tell late ones apart)
    assert w.newest == 9


def test_a_tick_checked_without_setting_the_window_leaves_it_where_it_was() -> None:
    w = TickWindow()
    assert w.ahead(10**15, 0) == ""  # nothing known yet
    assert w.newest is None
    w.refuse(8, 0)
    assert w.ahead(8 + WINDOW_TICKS, 0) == ""
    assert "ahead of the world's tick 8" in w.ahead(10**15, 0)
    assert w.newest == 8  # neither moved it


def test_a_receiver_that_was_stalled_catches_up_with_the_world() -> None:
    w = TickWindow()
    w.refuse(100, 0)
    far = 100 + WINDOW_TICKS + 5 * MAX_TICKS_PER_S
    assert w.refuse(far, 1 * S) != ""  # one second cannot hold five seconds of ticks...
    assert w.refuse(far, 5 * S) == ""  # ...five seconds can
    assert w.newest == far


def test_the_worlds_own_word_moves_the_window_even_back() -> None:
    w = TickWindow()
    w.refuse(10**15, 0)  # a forged first message, before the world said anything
    w.anchor(40, 0)
    assert w.refuse(10**15, 0) != ""
    assert w.refuse(41, 0) == ""


@dataclass
class _Info:
    tick: int
    revision: int


@dataclass
class _View:
    info: _Info
    specs: dict[int, object] = field(default_factory=dict)


def test_a_view_window_anchors_on_the_world_info_and_refuses_robots_the_world_does_not_have() -> None:
    view = _View(_Info(tick=500, revision=3), {1: "spec", 2: "spec"})
    w: ViewWindow[_View] = ViewWindow(lambda rev: view if rev <= 3 else None)
    got, why = w.view(world_state(10**15, [1], revision=3), 0)  # a forged first state: the info is the anchor
    assert got is None
    assert "ahead of the world's tick 500" in why
    assert w.view(world_state(501, [1, 2], revision=3), 0) == (view, "")
    got, why = w.view(world_state(502, [1, 9], revision=3), 0)
    assert got is None
    assert "robots [9] are not in the world's revision 3" in why
    assert w.view(world_state(502, [1, 7], revision=2), 0) == (None, "")  # an older roster: late, not bad
    assert w.view(world_state(503, [1], revision=4), 0) == (None, "")  # no world info for it (yet)


class _Forward:
    def spec(self) -> RobotSpec:
        return RobotSpec("fwd")

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        return Command(0.1, 0.1)


def _reading(tick: int, rid: int = 1) -> SensorReading:
    return SensorReading(
        tick=tick, robot_id=rid, proximity_ids=[], proximity_m=[], proximity_legacy=[], compass_deg=0.0, gps=(0, 0, 0)
    )


def _host(world_tick: int) -> tuple[AgentHost, FakeBus]:
    return agent_host(_Forward(), world_tick=world_tick)


def _answered(bus: FakeBus) -> list[int]:
    return [decode(d, Actions).tick for k, d in bus.published if k == keys.actions("t", 1)]


def _bad(bus: FakeBus) -> list[Event]:
    return [decode(d, Event) for k, d in bus.published if k == keys.event("t", "bad-message")]


def test_an_agent_refuses_a_reading_from_far_ahead_and_goes_on_answering_the_real_ticks() -> None:
    host, bus = _host(world_tick=50)
    key = keys.sensors("t", 1)
    host.readings.put((key, encode(_reading(10**15)), 0))
    host.step(timeout_s=0)
    assert _answered(bus) == []
    [bad] = _bad(bus)
    assert bad.key == key
    assert "tick 1000000000000000" in bad.reason
    for t in (51, 52):
        host.readings.put((key, encode(_reading(t)), 0))
        assert host.step(timeout_s=0)
    assert _answered(bus) == [51, 52]


def test_an_agent_refuses_a_radio_batch_from_far_ahead_and_a_reading_on_another_robots_key() -> None:
    host, bus = _host(world_tick=50)
    host.radio.put((keys.radio("t"), encode(RadioBatch(tick=10**12, hear=[Hear(robot_id=1)])), 0))
    host.readings.put((keys.sensors("t", 1), encode(_reading(51, rid=2)), 0))
    host.step(timeout_s=0)
    assert [e.key for e in _bad(bus)] == [keys.radio("t"), keys.sensors("t", 1)]
    assert "robot 2 on robot 1's key" in _bad(bus)[1].reason
    assert _answered(bus) == []


def test_a_registration_answer_that_does_not_decode_is_passed_over_for_one_that_does() -> None:
    bus = FakeBus()
    good = RegisterReply(tick=5, ok=True, robot_id=1, spec=RobotSpecMsg(name="fwd", id=1, x_m=1.0, y_m=1.0))
    bus.answer = lambda key, payload: [b'{"ok": "yes"}', encode(good)]
    host = AgentHost(bus, "t", "host")
    assert host.add(_Forward(), timeout_s=1.0) == 1


def test_a_registration_answer_that_is_refused_refuses_the_registration_with_its_reason() -> None:
    bus = FakeBus()
    bad = RegisterReply(tick=5, ok=True, robot_id=1, spec=RobotSpecMsg(name="fwd", id=1, width_m=-1.0))
    bus.answer = lambda key, payload: [encode(bad)]
    host = AgentHost(bus, "t", "host")
    with pytest.raises(RegistrationRefused, match="width"):
        host.add(_Forward(), timeout_s=1.0)


def test_radio_batches_of_ticks_not_answered_are_a_bounded_history() -> None:
    host, bus = _host(world_tick=50)
    for t in range(51, 51 + 5000):  # the radio goes on while the host has no reading to answer
        host.radio.put((keys.radio("t"), encode(RadioBatch(tick=t, sim_time_ns=t)), 0))
        host.step(timeout_s=0)
    assert _bad(bus) == []
    assert len(host._heard) <= HEARD_KEPT
    assert max(host._heard) == 5050  # the newest kept
    host.readings.put((keys.sensors("t", 1), encode(_reading(5050)), 0))
    assert host.step(timeout_s=0)
    assert _answered(bus) == [5050]


def test_a_second_reading_of_a_tick_not_answered_yet_replaces_the_first_and_of_one_answered_is_passed_over() -> None:
    # the sensors correct readings they sent before the world held the tick: a host still waiting
    # (lock-step, for its other robots or the radio) acts on the correction, once
    host, bus = _host(world_tick=50)
    seen: list[float] = []

    def on_sensors(reading: SensorReading, heard: list[Heard]) -> Command:
        seen.append(reading.compass_deg)
        return Command(0.1, 0.1)

    host.hosted[1].agent.on_sensors = on_sensors  # type: ignore[method-assign]
    key = keys.sensors("t", 1)
    for compass in (10.0, 20.0):
        host.readings.put((key, encode(msgspec.structs.replace(_reading(51), compass_deg=compass)), 0))
    assert host.step(timeout_s=0)
    host.readings.put((key, encode(msgspec.structs.replace(_reading(51), compass_deg=30.0)), 0))
    assert not host.step(timeout_s=0)  # answered already: not again
    assert seen == [20.0]
    assert _answered(bus) == [51]
