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
