from __future__ import annotations

import msgspec

from iw_zenoh.messages import Event, Hear, RadioBatch, Say, WorldState
from iw_zenoh.sim.radio import RadioConfig, RadioNode


def _state(xs: list[float]) -> WorldState:
    n = len(xs)
    return WorldState(
        tick=1,
        revision=1,
        ids=list(range(1, n + 1)),
        x=xs,
        y=[0.0] * n,
        heading=[0.0] * n,
        collided=[False] * n,
        rolled_left=[0.0] * n,
        rolled_right=[0.0] * n,
        speed=[0.0] * n,
    )


def _heard(out: list[tuple[str, object]]) -> dict[int, list[str]]:
    batch = next(m for _, m in out if isinstance(m, RadioBatch))
    return {h.robot_id: [x.text for x in h.messages] for h in batch.hear}


def test_messages_reach_only_robots_strictly_within_range_speaker_included() -> None:
    node = RadioNode("s", RadioConfig(range_m=8.0))
    node.on_say(Say(robot_id=1, text="hi"))
    out = node.on_state(_state([0.0, 7.99, 8.0, 20.0]))
    assert _heard(out) == {1: ["hi"], 2: ["hi"]}
    assert all(isinstance(m, Hear | RadioBatch) for _, m in out)


def test_long_messages_and_budget_overflows_are_dropped_and_counted() -> None:
    node = RadioNode("s", RadioConfig(max_message_bytes=100, max_heard_bytes=250))
    node.on_say(Say(robot_id=1, text="é" * 51))  # 102 bytes
    for rid in (1, 2, 3):
        node.on_say(Say(robot_id=rid, text=str(rid) * 100))
    out = node.on_state(_state([0.0, 1.0, 2.0]))
    heard = _heard(out)
    assert heard[1] == ["1" * 100, "2" * 100]  # sender order; the third would pass 250 bytes
    ev = next(m for _, m in out if isinstance(m, Event))
    assert ev.data == {"too_long": 1, "over_budget": 3}


def test_a_message_is_delivered_once() -> None:
    node = RadioNode("s")
    node.on_say(Say(robot_id=1, text="once"))
    assert _heard(node.on_state(_state([0.0])))[1] == ["once"]
    assert _heard(node.on_state(_state([0.0]))) == {}


def test_a_tick_delivered_early_is_checked_by_its_state_and_delivered_again_if_the_world_held_it() -> None:
    node = RadioNode("s", RadioConfig(range_m=8.0))
    node.on_say(Say(robot_id=1, text="hi"))
    proposed = _state([0.0, 7.5])
    assert _heard(node.send_early(proposed)) == {1: ["hi"], 2: ["hi"]}
    assert node.early_tick == 1
    node.on_say(Say(robot_id=2, text="next"))  # said after hearing tick 1: for tick 2
    assert node.check_early(proposed) == []  # where they were delivered at: nothing more
    assert node.early_tick is None
    # tick 2 delivered early at the proposal, but the world held robot 2 beyond the range
    proposed = msgspec.structs.replace(_state([0.0, 7.5]), tick=2)
    assert _heard(node.send_early(proposed)) == {1: ["next"], 2: ["next"]}
    held = msgspec.structs.replace(proposed, x=[0.0, 9.0], held=True)
    again = node.check_early(held)
    assert _heard(again) == {2: ["next"]}  # the same message, at the committed positions
    assert all(isinstance(m, Hear | RadioBatch) for _, m in again)
    assert node.corrections == 1
    assert _heard(node.on_state(msgspec.structs.replace(held, tick=3))) == {}  # delivered once: not again


def test_in_a_ciberrato_world_a_message_is_counted_in_characters_and_no_budget_drops_any() -> None:
    node = RadioNode("s")
    node.legacy = True
    text = "a" * 99 + "é"  # 100 characters, 101 bytes: the legacy simulator keeps it
    node.on_say(Say(robot_id=1, text=text))
    for rid in (2, 3, 4, 5):
        node.on_say(Say(robot_id=rid, text=str(rid) * 100))
    node.on_say(Say(robot_id=6, text="b" * 101))  # 101 characters: dropped, as the legacy one does
    out = node.on_state(_state([0.0, 1.0, 2.0, 3.0, 4.0, 5.0]))
    assert _heard(out)[1] == [text] + [str(rid) * 100 for rid in (2, 3, 4, 5)]  # 500 bytes, all heard
    ev = next(m for _, m in out if isinstance(m, Event))
    assert ev.data == {"too_long": 1}


def test_in_a_native_world_the_same_message_is_over_its_100_bytes() -> None:
    node = RadioNode("s")
    node.on_say(Say(robot_id=1, text="a" * 99 + "é"))
    out = node.on_state(_state([0.0]))
    assert _heard(out) == {}
