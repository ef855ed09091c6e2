"""What floods and clients that go cost the bridge node (fake sockets): one refusal event per
address and interval, bounded viewers, sockets closed when their client is gone."""

from __future__ import annotations

import pytest
from iw_zenoh.bridges.ciberrato import clients
from iw_zenoh.bridges.ciberrato.guard import RECEPTION_PER_S
from iw_zenoh.bridges.ciberrato.node import Bridge

from iw_zenoh import keys
from iw_zenoh.messages import Control, Event, RegisterReply, RegisterRequest, RobotSpecMsg, WorldState, decode, encode
from tests.support.fakes import FakeBus, FakeTransport, Rig

PEER = ("127.0.0.1", 40001)


def _refusals(bus: FakeBus) -> list[Event]:
    return [decode(d, Event) for k, d in bus.published if k == keys.event("s", "legacy-refused")]


def _poll_until_empty(bridge: Bridge, t: FakeTransport) -> None:
    while t.inbox or t.refused:
        bridge.poll(0)


def test_a_flood_from_rotating_ports_is_one_event_a_second(rig: Rig, monkeypatch: pytest.MonkeyPatch) -> None:
    bridge, bus, reception, _ = rig
    now = [100.0]
    monkeypatch.setattr("iw_zenoh.bridges.ciberrato.node.time.monotonic", lambda: now[0])
    for i in range(3000):
        reception.deliver(b"\xff\xfe junk", ("127.0.0.1", 20000 + i))
    _poll_until_empty(bridge, reception)
    assert len(_refusals(bus)) == 1  # the first, at once
    now[0] += 1.0
    bridge.poll(0)
    first, summary = _refusals(bus)
    assert first.data["count"] == 1
    assert summary.data["count"] == 2999  # the rest, counted: 1000 within the address's budget
    assert summary.data["dropped"] == 2999 - 999  # and the others dropped unread
    assert summary.data["peer"].startswith("127.0.0.1:")
    now[0] += 5.0
    bridge.poll(0)
    assert len(_refusals(bus)) == 2  # nothing refused since: nothing told


def test_a_viewer_asking_again_is_answered_from_its_own_socket(rig: Rig, monkeypatch: pytest.MonkeyPatch) -> None:
    bridge, _, reception, made = rig
    # a frozen clock: the address's budget is 1,000 a second, and a loaded machine can take
    # longer than a second to poll 2,000 datagrams (the bucket would refill as it went)
    monkeypatch.setattr("iw_zenoh.bridges.ciberrato.node.time.monotonic", lambda: 100.0)
    for _ in range(2000):
        reception.deliver(b"<View/>\n\x00", PEER)
    _poll_until_empty(bridge, reception)
    [own] = made.made  # one socket, however often it asks
    assert own.peer == PEER  # connected: only its viewer reaches it
    assert len(own.sent) == 1000  # answered within the address's budget, the rest dropped


def test_viewers_are_bounded_and_those_past_it_refused(rig: Rig, monkeypatch: pytest.MonkeyPatch) -> None:
    bridge, bus, reception, made = rig
    # a frozen clock: on a loaded machine the first viewers could fall silent past VIEWER_QUIET_S
    # before the last ask, and give them their places
    monkeypatch.setattr("iw_zenoh.bridges.ciberrato.node.time.monotonic", lambda: 100.0)
    for i in range(clients.MAX_VIEWERS + 5):
        reception.deliver(b"<View/>\n\x00", ("127.0.0.1", 30000 + i))
    _poll_until_empty(bridge, reception)
    assert len(made.made) == clients.MAX_VIEWERS
    assert len(reception.sent) == 5  # the others: the legacy refusal
    assert b'Status="Refused"' in reception.sent[0][0]
    assert "viewers and panels are served already" in _refusals(bus)[0].reason


def test_a_quiet_viewer_gives_its_place_when_all_are_taken(rig: Rig, monkeypatch: pytest.MonkeyPatch) -> None:
    bridge, _, reception, made = rig
    now = [100.0]
    monkeypatch.setattr("iw_zenoh.bridges.ciberrato.node.time.monotonic", lambda: now[0])
    for i in range(clients.MAX_VIEWERS):
        reception.deliver(b"<View/>\n\x00", ("127.0.0.1", 30000 + i))
    _poll_until_empty(bridge, reception)
    made.made[1].deliver(b"<LabReq/>\x00", ("127.0.0.1", 30001))  # a real one: it asked for the lab
    bridge.poll(0)
    now[0] += clients.VIEWER_QUIET_S + 0.5
    reception.deliver(b"<View/>\n\x00", PEER)
    bridge.poll(0)
    assert reception.sent == []  # served
    assert made.made[0].closed  # in the place of the oldest silent one
    assert not made.made[1].closed


def test_a_viewer_nobody_listens_for_any_more_is_let_go(rig: Rig) -> None:
    bridge, _, reception, made = rig
    reception.deliver(b"<View/>\n\x00", PEER)
    bridge.poll(0)
    [own] = made.made
    own.gone()
    bridge.poll(0)
    assert own.closed
    assert bridge.clients.viewers() == []


def test_a_silent_viewer_is_let_go_and_a_talking_one_kept(rig: Rig, monkeypatch: pytest.MonkeyPatch) -> None:
    bridge, _, reception, made = rig
    now = [100.0]
    monkeypatch.setattr("iw_zenoh.bridges.ciberrato.node.time.monotonic", lambda: now[0])
    reception.deliver(b"<View/>\n\x00", PEER)
    reception.deliver(b"<View/>\n\x00", ("127.0.0.1", 40002))
    _poll_until_empty(bridge, reception)
    silent, talking = made.made
    now[0] += 3.0
    talking.deliver(b"<LabReq/>\x00", ("127.0.0.1", 40002))
    bridge.poll(0)
    now[0] += clients.VIEWER_HANDSHAKE_S
    bridge.poll(0)
    assert silent.closed
    assert not talking.closed
    now[0] += 3600  # a real viewer watches in silence, for as long as it likes
    bridge.poll(0)
    assert not talking.closed


def test_a_robot_the_world_no_longer_holds_is_let_go(rig: Rig, monkeypatch: pytest.MonkeyPatch) -> None:
    bridge, bus, reception, made = rig
    now = [100.0]
    monkeypatch.setattr("iw_zenoh.bridges.ciberrato.node.time.monotonic", lambda: now[0])
    reception.deliver(b'<Robot Id="7" Name="bot1" />', PEER)
    bridge.poll(0)
    [own] = made.made
    states = bus.queue(keys.state("s"))

    def state(tick: int, ids: list[int]) -> None:
        n = len(ids)
        z = [0.0] * n
        st = WorldState(
            tick=tick,
            revision=0,
            ids=ids,
            x=z,
            y=z,
            heading=z,
            collided=[False] * n,
            rolled_left=z,
            rolled_right=z,
            speed=z,
        )
        states.put(keys.state("s"), encode(st))
        bridge.poll(0)

    state(1, [7])
    now[0] += clients.ROBOT_GONE_S + 1  # a world paused: no state, nothing let go
    bridge.poll(0)
    assert not own.closed
    state(2, [7])
    now[0] += 1.0
    state(3, [])  # removed: one state without it is not enough (a state in flight)
    assert not own.closed
    now[0] += clients.ROBOT_GONE_S
    state(4, [])
    assert own.closed
    assert 7 not in bridge.robots
    assert bridge.clients.by_robot == {}


def test_a_robot_nobody_listens_for_stays_in_the_world_and_is_told_once(rig: Rig) -> None:
    bridge, _, reception, made = rig
    reception.deliver(b'<Robot Id="7" Name="bot1" />', PEER)
    bridge.poll(0)
    [own] = made.made
    own.gone()
    bridge.poll(0)
    assert not own.closed
    assert bridge.clients.by_robot[7].unreachable


def test_registrations_with_no_world_ask_for_its_description_once_in_a_while(
    rig: Rig, monkeypatch: pytest.MonkeyPatch
) -> None:
    bridge, bus, reception, _ = rig
    # a frozen clock: the 500 registrations all fall within one INFO_ASK_S however slowly a
    # loaded machine polls them
    monkeypatch.setattr("iw_zenoh.bridges.ciberrato.node.time.monotonic", lambda: 100.0)
    asked: list[str] = []
    query = bus.query

    def counted(key: str, payload: bytes = b"", timeout_s: float = 2.0) -> list[bytes]:
        asked.append(key)  # the real one waits up to 2 s when no world answers
        return query(key, payload, timeout_s)

    bus.query = counted  # type: ignore[method-assign]
    for i in range(500):
        reception.deliver(b"<View/>\n\x00", ("127.0.0.1", 30000 + i))
    _poll_until_empty(bridge, reception)
    assert len(asked) == 1


def test_no_socket_left_for_a_client_is_a_refusal_not_the_end(rig: Rig) -> None:
    bridge, bus, reception, made = rig

    def exhausted() -> FakeTransport:
        raise OSError(24, "Too many open files")

    bridge.new_transport = exhausted
    reception.deliver(b"<View/>\n\x00", PEER)
    reception.deliver(b'<Robot Id="7" Name="bot1" />', ("127.0.0.1", 40002))
    bridge.poll(0)
    bridge.poll(0)
    assert "Too many open files" in _refusals(bus)[0].reason
    bridge.new_transport = made
    reception.deliver(b"<View/>\n\x00", ("127.0.0.1", 40003))
    bridge.poll(0)
    assert made.made[-1].sent  # still serving


def test_the_registration_port_is_read_within_its_budget_then_left_alone(
    rig: Rig, monkeypatch: pytest.MonkeyPatch
) -> None:
    bridge, bus, reception, _ = rig
    now = [100.0]
    monkeypatch.setattr("iw_zenoh.bridges.ciberrato.node.time.monotonic", lambda: now[0])
    for i in range(RECEPTION_PER_S + 1000):  # spoofed addresses: each within its own budget
        reception.deliver(b"junk", (f"10.0.{i // 256}.{i % 256}", 5000))
    for _ in range(200):
        bridge.poll(0)
    assert len(reception.inbox) == 1000 - 1  # the rest of the second: not read (the kernel drops)
    now[0] += 1.0
    _poll_until_empty(bridge, reception)  # a new second: read again
    assert sum(e.data["count"] for e in _refusals(bus)) <= RECEPTION_PER_S + 1000


def test_a_client_address_no_socket_can_talk_to_leaves_no_socket_behind(rig: Rig) -> None:
    bridge, bus, reception, made = rig

    def refusing(peer: tuple[str, int], /) -> None:
        raise PermissionError(13, "Permission denied")

    reception.deliver(b"<View/>\n\x00", ("255.255.255.255", 9))

    def making() -> FakeTransport:
        t = made()
        t.connect = refusing  # type: ignore[method-assign]
        return t

    bridge.new_transport = making
    bridge.poll(0)
    assert made.made[-1].closed
    assert "Permission denied" in _refusals(bus)[0].reason
    assert bridge.clients.viewers() == []


def test_failed_sends_are_logged_once_a_second_with_their_count(
    rig: Rig, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    bridge, _, reception, made = rig
    # a frozen clock: a loaded machine can take longer than the second to make the 1,000 sends
    monkeypatch.setattr("iw_zenoh.bridges.ciberrato.clients.time.monotonic", lambda: 100.0)
    reception.deliver(b"<View/>\n\x00", PEER)
    bridge.poll(0)
    [own] = made.made

    def full(data: bytes, peer: tuple[str, int], /) -> int:
        raise BlockingIOError(11, "Resource temporarily unavailable")

    own.sendto = full  # type: ignore[method-assign]
    viewer = bridge.clients.viewers()[0]
    for _ in range(1000):
        bridge.clients.send(viewer, b"<Robot/>")
    lines = [r for r in caplog.records if "cannot send" in r.getMessage()]
    assert len(lines) == 1
    assert not own.closed  # a full buffer is not a gone viewer


def _controls(bus: FakeBus) -> list[Control]:
    return [decode(d, Control) for k, d in bus.published if k == keys.control("s")]


def _world_gives_asked_ids(bus: FakeBus) -> None:
    """The fake world accepts every robot with the id it asked for."""

    def accept(key: str, payload: bytes) -> list[bytes]:
        spec = decode(payload, RegisterRequest).spec
        return [encode(RegisterReply(ok=True, robot_id=spec.id, spec=RobotSpecMsg(name=spec.name, id=spec.id)))]

    bus.answer = accept


def test_robots_are_bounded_and_the_longest_silent_gives_its_place(rig: Rig, monkeypatch: pytest.MonkeyPatch) -> None:
    bridge, bus, reception, made = rig
    now = [100.0]
    monkeypatch.setattr("iw_zenoh.bridges.ciberrato.node.time.monotonic", lambda: now[0])
    bridge.clients.max_robots = 2
    _world_gives_asked_ids(bus)
    for i, peer in enumerate([("127.0.0.1", 41001), ("127.0.0.1", 41002)], start=1):
        reception.deliver(f'<Robot Id="{i}" Name="bot{i}" />'.encode(), peer)
        bridge.poll(0)
    first, second = made.made
    now[0] += clients.ROBOT_QUIET_S - 2
    second.deliver(b'<Actions LeftMotor="0.05" RightMotor="0.05"/>', ("127.0.0.1", 41002))
    bridge.poll(0)
    reception.deliver(b'<Robot Id="3" Name="bot3" />', PEER)  # both clients heard lately: refused
    bridge.poll(0)
    refusal = made.made[-1]  # answered from a socket of its own, closed at once
    assert b'Status="Refused"' in refusal.sent[0][0]
    assert refusal.closed
    assert "2 legacy robots are served" in _refusals(bus)[-1].reason
    assert set(bridge.clients.by_robot) == {1, 2}
    assert _controls(bus) == []

    now[0] += 3  # robot 1's client silent past ROBOT_QUIET_S (a flood's registrations never speak)
    reception.deliver(b'<Robot Id="3" Name="bot3" />', PEER)
    bridge.poll(0)
    assert first.closed  # its socket given back
    assert not second.closed
    assert set(bridge.clients.by_robot) == {2, 3}  # the new robot served in its place
    assert [(c.command, c.robot_id) for c in _controls(bus)] == [("remove", 1)]  # nobody drives robot 1 now


def test_a_robot_nobody_listens_for_gives_its_place_first(rig: Rig) -> None:
    bridge, bus, reception, made = rig
    bridge.clients.max_robots = 2
    _world_gives_asked_ids(bus)
    for i, peer in enumerate([("127.0.0.1", 41001), ("127.0.0.1", 41002)], start=1):
        reception.deliver(f'<Robot Id="{i}" Name="bot{i}" />'.encode(), peer)
        bridge.poll(0)
    first, second = made.made
    second.gone()
    bridge.poll(0)
    reception.deliver(b'<Robot Id="3" Name="bot3" />', PEER)
    bridge.poll(0)
    assert second.closed
    assert not first.closed
    assert set(bridge.clients.by_robot) == {1, 3}
