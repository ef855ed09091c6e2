"""A bus holds what is declared now: subscriptions undeclared one by one (an agent host drops a
removed robot's) leave its table, and what stays declared still receives."""

from __future__ import annotations

import socket
import threading
import time
from pathlib import Path

import pytest

from iw_zenoh.bus import Inbox
from iw_zenoh.bus.net import free_port
from tests.integration import harness
from tests.integration.harness import Net


def test_undeclared_subscriptions_leave_the_bus_and_the_rest_still_receive(net: Net) -> None:
    bus = net.client()
    base = bus.declared()
    kept = Inbox()
    bus.subscribe("iw/t/kept", kept)
    for i in range(2_000):  # robots coming and going, each with its own subscription
        bus.subscribe(f"iw/t/robot/{i}", Inbox()).undeclare()
        bus.token(f"iw/t/alive/agent/a{i}").undeclare()
    assert bus.declared() == base + 1
    bus.publish("iw/t/kept", b"still here")
    got = kept.get(timeout_s=10)
    assert got is not None
    assert got[1] == b"still here"


def test_a_delivery_names_its_samples_key_for_a_plain_key_and_for_a_pattern(net: Net) -> None:
    bus = net.client()
    plain, pattern = Inbox(), Inbox()
    bus.subscribe("iw/t/robot/7/sensors", plain)
    bus.subscribe("iw/t/robot/*/sensors", pattern)
    for rid in (7, 8):
        bus.publish(f"iw/t/robot/{rid}/sensors", str(rid).encode())
    got = plain.get(timeout_s=10)
    assert got is not None
    assert got[:2] == ("iw/t/robot/7/sensors", b"7")
    seen = [pattern.get(timeout_s=10) for _ in range(2)]
    assert sorted((d[0], d[1]) for d in seen if d is not None) == [
        ("iw/t/robot/7/sensors", b"7"),
        ("iw/t/robot/8/sensors", b"8"),
    ]


def test_a_query_returns_every_repliers_answer_not_only_the_last_to_arrive(net: Net) -> None:
    """Zenoh's default consolidation keeps one answer per key, the last to arrive: with a second
    world on the key, the first world's answer (the prompt one: a held world answers every 10 ms)
    was dropped at every query, and collision and sensors never had its description."""
    prompt, late, asker = net.client(), net.client(), net.client()
    served = [(prompt.serve("iw/t/world/info"), b"prompt", 0.0), (late.serve("iw/t/world/info"), b"late", 0.05)]
    stop = threading.Event()

    def answer() -> None:
        while not stop.is_set():
            for q_inbox, data, delay in served:
                for q in q_inbox.poll():
                    threading.Timer(delay, q.reply, (data,)).start()
            stop.wait(0.002)

    t = threading.Thread(target=answer, daemon=True)
    t.start()
    try:
        deadline = time.monotonic() + 10  # both queryables known to the router
        while len(got := asker.query("iw/t/world/info", timeout_s=2.0)) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert sorted(got) == [b"late", b"prompt"]
    finally:
        stop.set()
        t.join(2)


def test_a_router_that_cannot_take_its_port_is_not_taken_for_listening(tmp_path: Path) -> None:
    """The port in use was the only sign the router listened: held by another (a parallel test's
    router), the test went on against that one, sharing its keys."""
    other = socket.socket()
    other.bind(("127.0.0.1", 0))
    other.listen()
    n = Net(tmp_path, port=other.getsockname()[1])
    try:
        with pytest.raises(AssertionError, match="router died"):
            n.start_router()
    finally:
        n.close()
        other.close()


def test_a_router_port_taken_before_it_binds_is_traded_for_another(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A port the harness chose and another took meanwhile (free_port's race): the router is
    started again on another port, and the test runs against its own router."""
    other = socket.socket()
    other.bind(("127.0.0.1", 0))
    other.listen()
    taken = other.getsockname()[1]
    ports = iter([taken, free_port()])
    monkeypatch.setattr(harness, "free_port", lambda: next(ports))
    n = Net(tmp_path)
    try:
        router = n.start_router()
        assert n.port != taken
        assert f":{n.port}" in router.output()
        first = next(p for p in n.procs if p.name == "router")
        assert first.popen.poll() is not None  # it died on the taken port, and said so in its own log
        assert f":{taken}" in first.output() or "in use" in first.output()
        assert router.name == "router-2"
    finally:
        n.close()
        other.close()
