"""The world's actions inbox wakes its loop once per tick (CountedWake): held, deliveries are
counted and wake the loop only when as many came as robots are still expected; a miscount in the
safe direction (duplicates, forgeries) wakes it early, never late; released, every delivery wakes."""

from __future__ import annotations

import threading

from iw_zenoh.bus import Delivery, Inbox
from iw_zenoh.bus.wake import CountedWake


def _d(i: int) -> Delivery:
    return ("k", str(i).encode(), i)


def _deliver(box: Inbox, n: int) -> None:
    for i in range(n):
        box.put(_d(i))


def _held(event: threading.Event) -> tuple[CountedWake, Inbox]:
    wake = CountedWake(event)
    wake.hold()
    return wake, Inbox(wake=wake)


def test_released_every_delivery_wakes_the_loop_as_a_plain_event() -> None:
    event = threading.Event()
    box = Inbox(wake=CountedWake(event))
    box.put(_d(0))
    assert event.is_set()
    event.clear()
    box.put(_d(1))
    assert event.is_set()


def test_held_the_nth_delivery_wakes_the_loop_not_the_one_before() -> None:
    event = threading.Event()
    wake, box = _held(event)
    wake.wake_after(wake.seen, 3)
    box.put(_d(0))
    box.put(_d(1))
    assert not event.is_set()
    box.put(_d(2))
    assert event.is_set()
    assert len(box.drain()) == 3  # nothing is held back from the loop: only its wake-up


def test_held_without_a_target_nothing_wakes_and_a_target_already_met_wakes_at_once() -> None:
    event = threading.Event()
    wake, box = _held(event)
    mark = wake.seen  # the loop's mark, before it drains
    box.put(_d(0))
    box.put(_d(1))  # the proposal is out, the loop is still busy with the tick: no wake-up
    assert not event.is_set()
    wake.wake_after(mark, 2)  # both came since the mark: the loop must not sleep on them
    assert event.is_set()


def test_a_new_mark_counts_anew() -> None:
    event = threading.Event()
    wake, box = _held(event)
    wake.wake_after(wake.seen, 2)
    box.put(_d(0))
    box.put(_d(1))
    assert event.is_set()
    event.clear()
    box.drain()
    wake.wake_after(wake.seen, 2)  # the next pass (or tick): two more are needed again
    box.put(_d(2))
    assert not event.is_set()
    box.put(_d(3))
    assert event.is_set()


def test_beyond_the_target_every_delivery_wakes_and_none_needed_wakes_at_once() -> None:
    event = threading.Event()
    wake, box = _held(event)
    wake.wake_after(wake.seen, 1)
    box.put(_d(0))  # a duplicate, say: the loop wakes early, finds the tick waiting, sleeps again
    event.clear()
    box.put(_d(1))
    assert event.is_set()
    event.clear()
    wake.wake_after(wake.seen, 0)
    assert event.is_set()


def test_released_after_a_hold_wakes_at_once_again() -> None:
    event = threading.Event()
    wake, box = _held(event)
    wake.wake_after(wake.seen, 5)
    box.put(_d(0))
    assert not event.is_set()
    wake.release()
    assert not wake.held
    box.put(_d(1))
    assert event.is_set()


def test_deliveries_racing_the_target_are_never_passed_unseen() -> None:
    """A producer thread delivers while the loop names targets: once the loop has named a target
    that the deliveries already made reach, the event is set (no delivery slips between the
    count and the target)."""
    for _ in range(200):
        event = threading.Event()
        wake, box = _held(event)
        mark = wake.seen
        producer = threading.Thread(target=_deliver, args=(box, 4))
        producer.start()
        wake.wake_after(mark, 4)
        producer.join()
        assert event.is_set()
        assert len(box.drain()) == 4
