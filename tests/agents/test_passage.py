"""The passage protocol: every transition, lost messages, timeouts, a vanished chair, a race."""

from __future__ import annotations

import random

import pytest
from hypothesis import given
from hypothesis import strategies as st
from iw_zenoh.agents.passage import Answer, Arbiter, Ask, Client, Passed, join, parse, parse_all


def test_every_message_reads_back_and_fits_the_radio() -> None:
    msgs = [
        Ask(12, 345, 12.5, 7),
        Answer("GRANT", 12, 345, 7),
        Answer("WAIT", 12, 345, 7, place=2),
        Answer("REFUSE", 12, 345, 7, why="full"),
        Passed(12, 345),
    ]
    for m in msgs:
        assert len(m.text().encode()) <= 100
        assert parse(m.text()) == m


@given(st.text(max_size=120))
def test_anything_else_on_the_radio_is_not_a_protocol_message_and_never_raises(text: str) -> None:
    m = parse(text)
    assert m is None or m.text().split()[0] == text.split()[0]
    parse_all(text)


def test_several_answers_pack_into_one_message_of_at_most_100_bytes() -> None:
    texts = [Answer("WAIT", 1, 100 + i, 9999, place=i).text() for i in range(8)]
    packed, rest = join(texts)
    assert packed is not None
    assert len(packed.encode()) <= 100
    assert rest
    assert [m.text() for m in parse_all(packed)] + rest == texts


def test_the_first_chair_waits_while_the_door_opens_then_is_granted() -> None:
    door = Arbiter(1)
    assert door.step([Ask(1, 5, 3.0, 1)], 0.0, door_open=False) == [Answer("WAIT", 1, 5, 1, place=0)]
    assert door.wanted  # so the door opens
    assert door.step([Ask(1, 5, 2.0, 2)], 1.0, door_open=True) == [Answer("GRANT", 1, 5, 2)]
    assert door.holder == 5


def test_one_chair_at_a_time_in_order_of_arrival() -> None:
    door = Arbiter(1)
    door.step([Ask(1, 7, 9.0, 1), Ask(1, 5, 4.0, 1), Ask(1, 6, 6.0, 1)], 0.0, door_open=True)
    assert door.holder == 5  # arrives first
    out = door.step([Ask(1, 6, 5.0, 2), Ask(1, 7, 8.0, 2)], 1.0, door_open=True)
    assert out == [Answer("WAIT", 1, 6, 2, place=0), Answer("WAIT", 1, 7, 2, place=1)]
    out = door.step([Passed(1, 5), Ask(1, 6, 1.0, 3), Ask(1, 7, 7.0, 3)], 2.0, door_open=True)
    assert out == [Answer("GRANT", 1, 6, 3), Answer("WAIT", 1, 7, 3, place=0)]


def test_two_chairs_racing_in_one_tick_are_ordered_the_same_way_every_time() -> None:
    for order in ([Ask(1, 8, 5.0, 1), Ask(1, 3, 5.0, 1)], [Ask(1, 3, 5.0, 1), Ask(1, 8, 5.0, 1)]):
        door = Arbiter(1)
        door.step(order, 0.0, door_open=True)
        assert door.holder == 3  # same arrival: the lower id, whatever the order heard


def test_a_holder_that_goes_silent_loses_the_doorway_and_the_next_gets_it() -> None:
    door = Arbiter(1, silent_s=3.0)
    door.step([Ask(1, 5, 1.0, 1), Ask(1, 6, 2.0, 1)], 0.0, door_open=True)
    assert door.holder == 5
    door.step([Ask(1, 6, 2.0, 2)], 2.0, door_open=True)
    assert door.holder == 5  # silent 2 s: still holds
    out = door.step([Ask(1, 6, 1.0, 3)], 3.5, door_open=True)
    assert door.holder == 6
    assert out == [Answer("GRANT", 1, 6, 3)]
    assert any("5 silent" in line for line in door.log)


def test_a_holder_too_long_in_the_doorway_is_released_for_the_next() -> None:
    door = Arbiter(1, hold_s=10.0)
    for t in range(12):
        door.step([Ask(1, 5, 1.0, t + 1), Ask(1, 6, 5.0, t + 1)], float(t), door_open=True)
        if t <= 10:
            assert door.holder == 5
    assert door.holder == 6  # 5 held the doorway over 10 s: it goes back in the queue
    assert any("5 released" in line for line in door.log)


def test_a_silent_chair_leaves_the_queue_and_the_door_may_close() -> None:
    door = Arbiter(1, silent_s=3.0)
    door.step([Ask(1, 5, 1.0, 1)], 0.0, door_open=False)
    assert door.wanted
    door.step([], 3.5, door_open=False)
    assert not door.wanted


def test_a_full_queue_refuses_and_the_chair_may_ask_again() -> None:
    door = Arbiter(1, max_queue=2)
    out = door.step([Ask(1, 5, 1.0, 1), Ask(1, 6, 2.0, 1), Ask(1, 7, 3.0, 1)], 0.0, door_open=False)
    assert out[-1] == Answer("REFUSE", 1, 7, 1, why="full")
    door.step([Passed(1, 5), Ask(1, 6, 2.0, 2)], 1.0, door_open=False)
    assert door.step([Ask(1, 7, 2.0, 2)], 1.5, door_open=False) == [Answer("WAIT", 1, 7, 2, place=1)]


def test_messages_for_another_door_are_none_of_its_business() -> None:
    door = Arbiter(1)
    assert door.step([Ask(2, 5, 1.0, 1), Passed(2, 5)], 0.0, door_open=True) == []
    assert not door.wanted


def test_the_chair_asks_again_until_answered_and_only_trusts_fresh_answers() -> None:
    c = Client(1, 5, ask_every_s=1.0)
    assert c.say(0.0, wants=True, eta_s=5.0, through=False) == "ASK 1 5 5.0 1"
    assert c.say(0.5, wants=True, eta_s=5.0, through=False) is None  # not yet
    assert c.say(1.0, wants=True, eta_s=4.0, through=False) == "ASK 1 5 4.0 1"  # lost: same request
    c.hear([Answer("GRANT", 1, 5, 0)], 1.1)  # an answer to an old request: ignored
    assert not c.granted(1.1)
    c.hear([Answer("GRANT", 1, 5, 1)], 1.2)
    assert c.granted(1.2)
    assert c.say(2.0, wants=True, eta_s=1.0, through=False) == "ASK 1 5 1.0 2"  # renewing
    assert not c.granted(4.0)  # the grant lapses if no answer renews it


def test_a_wait_takes_a_grant_back_and_passing_is_said_three_times() -> None:
    c = Client(1, 5)
    c.say(0.0, wants=True, eta_s=1.0, through=False)
    c.hear([Answer("GRANT", 1, 5, 1)], 0.1)
    c.say(1.0, wants=True, eta_s=1.0, through=False)
    c.hear([Answer("WAIT", 1, 5, 2, place=0)], 1.1)
    assert not c.granted(1.1)
    said = [c.say(2.0 + i, wants=False, eta_s=0.0, through=True) for i in range(4)]
    assert said[:3] == ["PASSED 1 5"] * 3
    assert said[3] is None


@pytest.mark.parametrize(("loss", "seed"), [(0.0, 0), (0.3, 1), (0.3, 2), (0.5, 3)])
def test_chairs_and_door_reach_the_end_with_lost_messages(loss: float, seed: int) -> None:
    """Two chairs, one door, a share of the messages lost both ways: both get through, never two
    in the doorway at once."""
    rng = random.Random(seed)
    door = Arbiter(1)
    chairs = {5: Client(1, 5), 6: Client(1, 6)}
    through: set[int] = set()
    in_doorway: dict[int, float] = {}
    door_open = False
    for tick in range(600):
        now = tick * 0.1
        said = []
        for cid, c in chairs.items():
            done = cid in through
            passing = cid in in_doorway and now - in_doorway[cid] > 2.0
            text = c.say(now, wants=not done and not passing, eta_s=3.0 if cid == 5 else 4.0, through=passing)
            if passing:
                through.add(cid)
                in_doorway.pop(cid)
            if text:
                said.append(text)
        heard = []
        for t in said:
            if rng.random() < loss:
                continue  # lost on the way to the door
            heard.extend(parse_all(t))
        answers = door.step(heard, now, door_open)
        door_open = door.wanted or door_open
        for a in answers:
            if rng.random() < loss:
                continue
            for c in chairs.values():
                c.hear([a], now)
        holders = [cid for cid, c in chairs.items() if c.granted(now)]
        assert len(holders) <= 1  # never two in the doorway
        for cid in holders:
            in_doorway.setdefault(cid, now)
        if through == {5, 6}:
            break
    assert through == {5, 6}
