"""An agent host answers a tick on the thread that delivers its last input (InlineAnswers): no
hand-off to the loop's thread per tick; the loop answers when that thread finds the host busy,
and an agent's error on a delivering thread ends the loop as it did on the loop's own."""

from __future__ import annotations

import threading

import pytest

from iw_zenoh import keys
from iw_zenoh.agent import AgentHost
from iw_zenoh.agent.hosting import Command
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import (
    Actions,
    Hear,
    Heard,
    RadioBatch,
    SensorReading,
    decode,
    encode,
)
from tests.support.builders import agent_host, bare_reading
from tests.support.fakes import FakeBus

KEY = keys.sensors("t", 1)


class _Recording:
    """Answers every reading, noting the thread it was called on; raises when told to."""

    def __init__(self, fail: bool = False) -> None:
        self.threads: list[int] = []
        self.heard: list[list[Heard]] = []
        self.fail = fail

    def spec(self) -> RobotSpec:
        return RobotSpec("fwd")

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        self.threads.append(threading.get_ident())
        self.heard.append(heard)
        if self.fail:
            raise RuntimeError("the controller broke")
        return Command(0.1, 0.1)


def _host(agent: _Recording) -> tuple[AgentHost, FakeBus]:
    return agent_host(agent)


def _answered(bus: FakeBus) -> list[int]:
    return [decode(d, Actions).tick for k, d in bus.published if k == keys.actions("t", 1)]


def _deliver(host: AgentHost, tick: int) -> int:
    """Puts a reading into the host's inbox from a thread of its own, as the bus does; returns
    that thread's id once it is done."""
    who: list[int] = []

    def put() -> None:
        who.append(threading.get_ident())
        host.readings.put((KEY, bare_reading(tick), 0))

    t = threading.Thread(target=put)
    t.start()
    t.join(10)
    assert not t.is_alive()
    return who[0]


def test_while_the_host_runs_a_delivery_answers_its_tick_on_the_delivering_thread_without_waking_the_loop() -> None:
    agent = _Recording()
    host, bus = _host(agent)
    host.inline.active = True
    host.io.wake.clear()
    delivering = _deliver(host, 51)
    assert _answered(bus) == [51]  # answered before the put returned
    assert agent.threads == [delivering]
    assert not host.io.wake.is_set()  # the loop's thread was not woken for it


def test_a_delivery_that_finds_the_host_busy_wakes_the_loop_which_answers_it() -> None:
    agent = _Recording()
    host, bus = _host(agent)
    host.inline.active = True
    host.io.wake.clear()
    with host.inline.lock:  # the loop is answering or checking its other inboxes
        _deliver(host, 51)
        assert _answered(bus) == []
    assert host.io.wake.is_set()
    assert host.step(timeout_s=0)
    assert _answered(bus) == [51]
    assert agent.threads == [threading.get_ident()]


def test_before_the_host_runs_a_delivery_only_wakes_the_loop() -> None:
    agent = _Recording()
    host, bus = _host(agent)
    host.io.wake.clear()
    _deliver(host, 51)  # registering the next agent, say: nothing answered behind add()'s back
    assert _answered(bus) == []
    assert host.io.wake.is_set()
    assert host.step(timeout_s=0)
    assert _answered(bus) == [51]


def test_an_agents_error_on_a_delivering_thread_ends_the_hosts_run_with_that_error() -> None:
    agent = _Recording(fail=True)
    host, bus = _host(agent)
    host.inline.active = True
    _deliver(host, 51)
    assert isinstance(host.inline.failure, RuntimeError)
    with pytest.raises(RuntimeError, match="the controller broke"):
        host.run()
    assert not host.inline.active
    assert _answered(bus) == []


def test_each_robot_answered_on_its_own_delivery_gets_what_it_heard_that_tick() -> None:
    """Real time, two robots in one process: the first robot's reading answers it at once, and the
    second's, delivered later, must still find the tick's radio batch."""
    one, two = _Recording(), _Recording()
    host, bus = agent_host(one, two)
    host.inline.active = True
    said = [Heard(sender=9, distance_m=2.5, text="door 4 opening")]
    batch = RadioBatch(tick=51, hear=[Hear(robot_id=1, messages=said), Hear(robot_id=2, messages=said)])
    host.radio.put((keys.radio("t"), encode(batch), 0))
    host.readings.put((keys.sensors("t", 1), bare_reading(51, 1), 0))
    host.readings.put((keys.sensors("t", 2), bare_reading(51, 2), 0))
    assert one.heard == [said]
    assert two.heard == [said]
