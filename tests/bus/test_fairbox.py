"""FairInbox: one key flooding keeps only its newest per_key waiting and never pushes another
key's deliveries out; a bounded number of keys."""

from __future__ import annotations

import logging
import threading

import pytest

from iw_zenoh.bus.fairbox import FairInbox


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


def test_keys_the_reader_does_not_know_take_only_their_own_few_places() -> None:
    known = {f"robot/{k}/actions" for k in range(5_000)}
    box = FairInbox(1, keys_kept=5_000, known=known.__contains__, strangers_kept=8)
    for k in range(10_000, 20_000):  # invented keys first
        box.put((f"robot/{k}/actions", b"x", 0))
    for key in known:
        box.put((key, b"y", 0))
    got = box.drain()
    assert {d[0] for d in got if d[1] == b"y"} == known
    assert len(got) == 5_000 + 8
    assert box.lost == box.dropped == 10_000 - 8


def test_len_wait_and_lost_see_the_keys_waiting() -> None:
    box = FairInbox(2)
    assert len(box) == 0
    assert not box.wait(0.01)
    for k in range(3):
        box.put(("robot/1/actions", str(k).encode(), 0))
    box.put(("robot/2/actions", b"x", 0))
    assert len(box) == 3
    assert box.lost == 1
    assert box.wait(0.01)
    woken = threading.Event()

    def waiter() -> None:
        if box.wait(30):
            woken.set()

    box.drain()
    t = threading.Thread(target=waiter)
    t.start()
    box.put(("robot/3/actions", b"x", 0))  # wakes the waiter at once, not at its timeout
    assert woken.wait(30)
    t.join(30)


def test_drops_are_logged_at_most_once_a_second_with_their_count(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a frozen clock: on a loaded machine the two rounds can be more than a second apart
    monkeypatch.setattr("iw_zenoh.bus.fairbox.time.monotonic", lambda: 100.0)
    caplog.set_level(logging.WARNING, logger="iw_zenoh.bus.fairbox")
    box = FairInbox(1, name="the test's inbox")
    for k in range(5):
        box.put(("robot/1/actions", str(k).encode(), 0))
    box.drain()
    for k in range(5):
        box.put(("robot/1/actions", str(k).encode(), 0))
    box.drain()  # within the second: not logged again
    [record] = caplog.records
    assert "the test's inbox dropped 4 deliveries" in record.getMessage()
