"""An agent host listens for its robot's readings before it asks the world for the robot: the
world expects the robot's answer from the first tick after accepting it (in lock-step it waits
for it), so a reading published before a subscription made after the answer would be lost and
the world would wait out its whole timeout (a laggard, and a run that no longer replays)."""

from __future__ import annotations

import pytest

from iw_zenoh import keys
from iw_zenoh.agent import AgentHost, RegistrationRefused
from iw_zenoh.agent.hosting import Command
from iw_zenoh.bus import Asked, Handle, Inbox
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import Heard, LabMsg, RegisterReply, RobotSpecMsg, SensorReading, WorldInfo, encode
from tests.support.builders import bare_reading
from tests.support.fakes import FakeBus

Deliver = tuple[str, str, bytes]  # the subscription's key expression, the sample's key, the payload


class _Agent:
    def __init__(self, rid: int) -> None:
        self.rid = rid

    def spec(self) -> RobotSpec:
        return RobotSpec("fwd", id=self.rid)

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        return Command(0.0, 0.0)


class _Subscription:
    def __init__(self, bus: _Watching, key: str) -> None:
        self.bus, self.key = bus, key

    def undeclare(self) -> None:
        self.bus.live.discard(self.key)


class _Watching(FakeBus):
    """Keeps the keys subscribed now, and those subscribed when the world was asked; delivers
    ``on_ask`` while the world is asked and ``on_info`` while the host asks world/info."""

    def __init__(self, given: int) -> None:
        super().__init__()
        self.live: set[str] = set()
        self.when_asked: set[str] = set()
        self.inboxes: dict[str, Inbox] = {}
        self.on_ask: list[Deliver] = []
        self.on_info: list[Deliver] = []
        spec = RobotSpecMsg(name="fwd", id=given, x_m=1.0, y_m=1.0)
        self.answer = lambda key, payload: [encode(RegisterReply(tick=5, ok=True, robot_id=given, spec=spec))]
        self.info = [encode(WorldInfo(tick=5, revision=1, lab=LabMsg(name="l", width=5, height=5), period_ns=1))]

    def subscribe(self, key_expr: str, inbox: Inbox, *, ordered: bool = False) -> Handle:
        self.live.add(key_expr)
        self.inboxes[key_expr] = inbox
        return _Subscription(self, key_expr)

    def ask(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> Asked:
        self.when_asked = set(self.live)
        for sub, k, data in self.on_ask:
            self.inboxes[sub].put((k, data, 0))
        return super().ask(key, payload, timeout_s)

    def query(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> list[bytes]:
        for sub, k, data in self.on_info:
            self.inboxes[sub].put((k, data, 0))
        return super().query(key, payload, timeout_s)


@pytest.mark.parametrize(("asked", "given"), [(3, 3), (0, 7)])
def test_the_robots_readings_are_heard_from_before_it_is_asked_for(asked: int, given: int) -> None:
    bus = _Watching(given)
    host = AgentHost(bus, "t", "host")
    assert host.add(_Agent(asked), timeout_s=1.0) == given
    # an id asked for: its own key; 0 (the world chooses): every robot's, until the answer says which
    assert (keys.sensors("t", asked) if asked else keys.all_sensors("t")) in bus.when_asked
    assert keys.sensors("t", given) in bus.live
    assert keys.all_sensors("t") not in bus.live  # every robot's readings: only while the id was unknown


def test_a_reading_heard_before_the_answer_never_overtakes_its_correction() -> None:
    """Every robot's key and the robot's own one deliver on threads of their own: a lagging
    copy of a tick's first reading (every robot's key) must not be taken after the sensors'
    correction of it (its own key), or the tick would be answered on the first."""
    bus = _Watching(7)
    every, own = keys.all_sensors("t"), keys.sensors("t", 7)
    first, corrected = bare_reading(6, 7), bare_reading(6, 7, 90.0)
    bus.on_ask = [(every, keys.sensors("t", 3), bare_reading(6, 3)), (every, own, first)]
    # the robot's own key brings both; every robot's key's copy of the first comes after them
    bus.on_info = [(own, own, first), (own, own, corrected), (every, own, first)]
    host = AgentHost(bus, "t", "host")
    assert host.add(_Agent(0), timeout_s=1.0) == 7
    host._collect()
    got = host.hosted[7].reading
    assert got is not None
    assert (got.tick, got.compass_deg) == (6, 90.0)  # the correction
    assert host._fresh == {6: 1}  # the tick counted once


@pytest.mark.parametrize("asked", [3, 0])
def test_an_answer_that_accepts_no_robot_is_refused_and_nothing_stays_subscribed(asked: int) -> None:
    """A world's "ok" names the robot: an answer of robot 0 (none) is not one, and the
    subscription made before asking goes with the refusal."""
    bus = _Watching(0)
    host = AgentHost(bus, "t", "host")
    with pytest.raises(RegistrationRefused, match="names no id"):
        host.add(_Agent(asked), timeout_s=1.0)
    assert not [k for k in bus.live if k.endswith("/sensors")]
