"""The bridge node's unit tests' rig: a Bridge on fake sockets and a fake bus whose registration
queries are accepted as robot 7."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from iw_zenoh.bridges.ciberrato.node import Bridge

from iw_zenoh.messages import RegisterReply, RobotSpecMsg, encode
from tests.support.fakes import FakeBus, FakeTransport, Rig, Transports


@pytest.fixture
def rig() -> Iterator[Rig]:
    """The bridge, its bus, its reception socket and the transports it made; closed after."""
    bus, reception, made = FakeBus(), FakeTransport(), Transports()
    accept = RegisterReply(ok=True, robot_id=7, spec=RobotSpecMsg(name="bot1", id=7, x_m=1.0, y_m=2.0))
    bus.answer = lambda key, payload: [encode(accept)]
    bridge = Bridge(bus, "s", reception, new_transport=made, pace=False)
    yield bridge, bus, reception, made
    bridge.close()
