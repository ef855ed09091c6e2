"""The inbox every node receives through: order kept, bounded inboxes keep the newest, a waiting
loop woken, nothing lost between a producer thread and the loop draining."""

from __future__ import annotations

import threading

from iw_zenoh.bus import Delivery, Inbox


def _d(i: int) -> Delivery:
    return ("k", str(i).encode(), i)


def test_drain_gives_everything_in_order_and_empties() -> None:
    box = Inbox()
    for i in range(5):
        box.put(_d(i))
    assert len(box) == 5
    assert [d[2] for d in box.drain()] == [0, 1, 2, 3, 4]
    assert box.drain() == []
    assert len(box) == 0


def test_a_bounded_inbox_keeps_the_newest() -> None:
    box = Inbox(maxlen=2)
    for i in range(5):
        box.put(_d(i))
    assert [d[2] for d in box.drain()] == [3, 4]


def test_wake_is_set_by_a_delivery_and_a_loop_clearing_it_before_draining_misses_nothing() -> None:
    wake = threading.Event()
    box = Inbox(wake=wake)
    box.put(_d(0))
    assert wake.is_set()
    box.put(_d(1))  # already set: left set
    wake.clear()
    box.put(_d(2))  # after the clear: set again
    assert wake.is_set()
    assert [d[2] for d in box.drain()] == [0, 1, 2]


def test_get_and_wait_are_woken_by_a_put_from_another_thread() -> None:
    box = Inbox()
    assert box.get(timeout_s=0.01) is None
    assert not box.wait(0.01)
    started = threading.Event()

    def later() -> None:
        started.wait(5)
        box.put(_d(7))

    t = threading.Thread(target=later)
    t.start()
    started.set()
    got = box.get(timeout_s=10)
    t.join(5)
    assert got == _d(7)
    t = threading.Thread(target=box.put, args=(_d(8),))
    t.start()
    assert box.wait(10)
    t.join(5)
    assert box.drain() == [_d(8)]


def test_a_producer_thread_and_a_draining_loop_lose_nothing() -> None:
    n = 50_000
    wake = threading.Event()
    box = Inbox(wake=wake)

    def produce() -> None:
        for i in range(n):
            box.put(_d(i))

    t = threading.Thread(target=produce)
    t.start()
    got: list[int] = []
    while len(got) < n:
        assert wake.wait(10), f"woken no more after {len(got)} of {n}"
        wake.clear()
        got += [d[2] for d in box.drain()]
    t.join(5)
    assert got == list(range(n))
    assert box.received == n


def test_losses_are_counted_the_same_however_often_an_empty_inbox_is_drained() -> None:
    box = Inbox(maxlen=2)
    assert box.drain() == []
    for i in range(5):
        box.put(_d(i))
    assert box.lost == 0  # counted when the inbox is read
    assert [d[2] for d in box.drain()] == [3, 4]
    assert box.lost == 3
    assert box.drain() == []
    box.put(_d(5))
    box.put(_d(6))
    box.put(_d(7))  # lost while nobody read: seen by the next read
    assert [d[2] for d in box.drain()] == [6, 7]
    assert box.lost == 4
