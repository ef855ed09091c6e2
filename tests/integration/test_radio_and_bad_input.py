"""Radio range and limits; malformed messages on every subscribed key."""

from __future__ import annotations

from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.messages import Event, Hear, RobotSpecMsg, Say, WorldState, decode, encode
from tests.integration.harness import (
    Net,
    register,
    start_world,
    subscribe,
    wait_alive,
    wait_event,
    wait_msg,
    watch,
)

pytestmark = [pytest.mark.zenoh, pytest.mark.timeout(120)]


def test_radio_delivers_within_range_and_enforces_byte_limits(net: Net) -> None:
    start_world(net, "radio")
    bus = net.client()
    hear = subscribe(bus, keys.all_hear(net.sim))
    events = subscribe(bus, keys.event(net.sim, "radio-dropped"))
    states = subscribe(bus, keys.state(net.sim), maxlen=1)
    # a at x=2; b 4 m away; c 10 m away; d..g near b, to fill b's 400-byte budget
    xs = {"a": 2.0, "b": 6.0, "c": 12.0, "d": 7.5, "e": 9.0, "f": 4.0, "g": 3.0}
    regs = {
        n: register(bus, net.sim, RobotSpecMsg(name=n, x_m=x, y_m=5.0, width_m=0.5, height_m=0.5))
        for n, x in xs.items()
    }
    assert all(r.ok for r in regs.values()), {n: r.reason for n, r in regs.items()}
    ids = {n: r.robot_id for n, r in regs.items()}
    wait_msg(states, WorldState, lambda m: len(m.ids) == len(xs))
    # the radio is the only subscriber of say: a state says nothing of it (its token comes after its inboxes)
    wait_alive(bus, keys.alive(net.sim, "radio", "radio"))

    bus.publish(keys.say(net.sim, ids["a"]), encode(Say(robot_id=ids["a"], text="hello")))
    heard = {}
    while len(heard) < 5:  # a, b, f, g within 8 m of a (and a itself); never c
        h = wait_msg(hear, Hear, timeout_s=10)
        assert h.robot_id != ids["c"], "c is 10 m away and must not hear a"
        heard[h.robot_id] = h
    assert ids["c"] not in heard
    assert [m.sender for m in heard[ids["a"]].messages] == [ids["a"]]  # the speaker hears itself
    assert heard[ids["b"]].messages[0].text == "hello"
    assert heard[ids["b"]].messages[0].distance_m == pytest.approx(4.0, abs=0.01)

    bus.publish(keys.say(net.sim, ids["b"]), encode(Say(robot_id=ids["b"], text="x" * 101)))
    dropped = wait_msg(events, Event, timeout_s=10)
    assert dropped.data == {"too_long": 1}

    # five 100-byte messages, all within 8 m of b; said again until they land in one tick
    # (a burst can straddle a tick boundary, and then nobody is over budget)
    over = None
    for _ in range(20):
        for n in ("a", "d", "e", "f", "g"):
            bus.publish(keys.say(net.sim, ids[n]), encode(Say(robot_id=ids[n], text=n * 100)))
        d = events.get(timeout_s=0.5)
        if d is not None and "over_budget" in (ev := decode(d[1], Event)).data:
            over = ev
            break
    assert over is not None, "five 100-byte messages never exceeded b's 400-byte budget"
    assert over.data["over_budget"] >= 1
    fullest = 0
    while (d := hear.get(timeout_s=0.5)) is not None:
        h = decode(d[1], Hear)
        if h.robot_id == ids["b"]:
            size = sum(len(m.text.encode()) for m in h.messages)
            assert size <= 400
            fullest = max(fullest, size)
    assert fullest == 400


def test_malformed_messages_are_dropped_with_an_event_and_nothing_else_changes(net: Net, tmp_path: Path) -> None:
    bus, events, states = watch(net)
    start_world(net, "collision", "sensors", "radio")
    net.spawn("agent", "waypoint", "--waypoints", "35,5", "--start", "3,5,0", "--name", "driver")
    first = wait_msg(states, WorldState, lambda m: len(m.ids) == 1 and m.speed[0] > 0.05 and not m.held)
    rid = first.ids[0]
    wait_alive(bus, keys.alive(net.sim, "radio", "radio"))  # say's only subscriber: a moving chair says nothing of it
    targets = [
        keys.actions(net.sim, rid),
        keys.pose_report(net.sim, rid),
        keys.control(net.sim),
        keys.verdict(net.sim),
        keys.proposed(net.sim),
        keys.state(net.sim),
        keys.say(net.sim, rid),
        keys.sensors(net.sim, rid),
        keys.radio(net.sim),
    ]
    for key in targets:
        bus.publish(key, b"{this is not json")
        bus.publish(key, b'{"robot_id": "seven"}')
    seen: set[str] = set()
    while not set(targets) <= seen:
        ev = wait_event(events, "bad-message", timeout_s=15, missing=lambda: set(targets) - seen)
        assert ev.reason
        seen.add(ev.key)
    later = wait_msg(states, WorldState, lambda m: m.tick > first.tick + 10)
    assert later.ids == [rid]
    assert not later.held
    assert later.x[0] > first.x[0]  # the chair kept driving
    kinds: list[str] = []
    while (d := events.get(timeout_s=0.2)) is not None:
        kinds.append(decode(d[1], Event).kind)
    assert not {"holding", "watchdog", "agent-lost", "removed"} & set(kinds)
