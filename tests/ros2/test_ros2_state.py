"""`iwz ros2`'s world side off Zenoh's thread: a state is only queued by the callback and published
by the role's own thread (a bad one refused there); a description that does not decode is refused
with its reason and the world asked again, not the role's exit."""

from __future__ import annotations

import threading
import time

from iw_zenoh import keys
from iw_zenoh.bus import Handle, Inbox
from iw_zenoh.messages import Event, WorldState, decode, encode
from iw_zenoh.nodes.ros2 import INFO_ASKS, StateToRos, tick_period_s
from iw_zenoh.process.runtime import NodeIO
from tests.bridges.fakes import FakeBus
from tests.nodes.test_info import _info  # a world's description (period 50 ms)


class _Bus(FakeBus):
    """Keeps the inboxes subscribed (the test delivers into them as Zenoh's thread would), and
    counts the queries."""

    def __init__(self) -> None:
        super().__init__()
        self.boxes: dict[str, Inbox] = {}
        self.queries = 0

    def subscribe(self, key_expr: str, inbox: Inbox, *, ordered: bool = False) -> Handle:
        self.boxes[key_expr] = inbox
        return super().subscribe(key_expr, inbox, ordered=ordered)

    def query(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> list[bytes]:
        self.queries += 1
        return super().query(key, payload, timeout_s)


class _Pub:
    def __init__(self) -> None:
        self.threads: list[str] = []

    def put(self, payload: bytes) -> None:
        self.threads.append(threading.current_thread().name)


class _Node:
    def __init__(self, pubs: list[_Pub]) -> None:
        self.pubs = pubs

    def publisher(self, *_: object) -> _Pub:
        self.pubs.append(_Pub())
        return self.pubs[-1]


class _Link:
    def __init__(self) -> None:
        self.pubs: list[_Pub] = []

    def node(self, *_: object) -> _Node:
        return _Node(self.pubs)


def _bad_keys(bus: FakeBus) -> list[str]:
    return [decode(d, Event).key for k, d in bus.published if k == keys.event("s", "bad-message")]


def _wait(pred: object, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not pred():  # type: ignore[operator]
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_a_state_is_published_by_the_roles_own_thread_and_a_bad_one_refused_there() -> None:
    bus, link = _Bus(), _Link()
    io = NodeIO(bus, "s", "agent", "ros2")
    state = StateToRos(link, {}, 0.1, io)  # type: ignore[arg-type]
    try:
        key = keys.state("s")
        st = WorldState(revision=0, tick=1, sim_time_ns=100, ids=[], x=[], y=[], heading=[], collided=[],
                        rolled_left=[], rolled_right=[], speed=[])  # fmt: skip
        bus.boxes[key].put((key, b"\xffnot a state", 0))  # as Zenoh's thread delivers: queued, no more
        bus.boxes[key].put((key, encode(st), 0))
        _wait(lambda: state.published == 1 and _bad_keys(bus) == [key])
    finally:
        state.close()
    clock = link.pubs[1]
    assert clock.threads == ["ros2-state"]  # published off Zenoh's thread, on the role's own


def test_a_description_that_does_not_decode_is_refused_and_the_good_one_taken() -> None:
    bus = _Bus()
    io = NodeIO(bus, "s", "agent", "ros2")
    bus.info = [b"\xffforged", encode(_info(0))]  # the forger's reply first, then the world's
    assert tick_period_s(bus, io) == 0.05
    assert _bad_keys(bus) == [keys.info("s")]
    bus.info = [b"\xffforged"]
    assert tick_period_s(bus, io, timeout_s=0.01) == 0.1  # asked again, then the default
    assert bus.queries == 1 + INFO_ASKS
