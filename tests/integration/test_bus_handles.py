"""A bus holds what is declared now: subscriptions undeclared one by one (an agent host drops a
removed robot's) leave its table, and what stays declared still receives."""

from __future__ import annotations

from iw_zenoh.bus import Inbox
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
