"""FairInbox: one key flooding keeps only its newest per_key waiting and never pushes another
key's deliveries out; a bounded number of keys."""

from __future__ import annotations

import threading

from iw_zenoh.fairbox import FairInbox


def test_a_flooded_key_keeps_its_newest_and_another_keys_delivery_survives() -> None:
    wake = threading.Event()
    box = FairInbox(4, wake)
    box.put(("agent/a/actions", b"a1", 0))
    for k in range(10_000):
        box.put(("agent/flood/actions", str(k).encode(), 0))
    assert wake.is_set()
    got = box.drain()
    assert ("agent/a/actions", b"a1", 0) in got
    assert [d[1] for d in got if d[0] == "agent/flood/actions"] == [b"9996", b"9997", b"9998", b"9999"]
    assert box.dropped == 10_000 - 4
    assert box.drain() == []


def test_keys_beyond_the_bound_are_dropped_and_counted() -> None:
    box = FairInbox(2, keys_kept=3)
    for k in range(5):
        box.put((f"robot/{k}/actions", b"x", 0))
    assert len(box.drain()) == 3
    assert box.dropped == 2
    box.put(("robot/9/actions", b"x", 0))  # drained: room again
    assert len(box.drain()) == 1
