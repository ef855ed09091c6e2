"""The serial bridge's registration, against the serial loop that runs beside it."""

from __future__ import annotations

from dataclasses import replace

import pytest

from bridges.serial.board import chair_spec
from bridges.serial.node import SerialBridge, _Chair
from iw_zenoh import keys
from iw_zenoh.bus import Handle, Inbox
from iw_zenoh.messages import Actions, Control, encode
from iw_zenoh.viewer.sources import LocalBus


@pytest.mark.parametrize("asked", [7, 0])
def test_every_inbox_is_declared_before_anything_of_the_chair_shows(asked: int) -> None:
    """The serial loop publishes the chair's readings as soon as ``robot_id`` is set. Set before
    the control inbox was declared, an operator who saw the first reading and pressed e-stop at
    once lost it (CI caught it: no e-stop in 5 s). The control key is heard from the start (the
    chair's link event comes before its registration); its actions' key before the world is
    asked when the id is asked for, else before the id is set."""
    added = False  # whether the world was asked yet
    declared: dict[str, tuple[bool, int]] = {}  # key: (asked yet, the bridge's robot_id then)
    bus = LocalBus(Inbox())
    bridge: SerialBridge | None = None
    subscribe = bus.subscribe

    def watched(key: str, inbox: Inbox, *, ordered: bool = False) -> Handle:
        declared[key] = (added, bridge.robot_id if bridge is not None else 0)
        return subscribe(key, inbox, ordered=ordered)

    def add(agent: object, **_: object) -> int:  # the world: the id asked for, else 9
        nonlocal added
        added = True
        return asked or 9

    bus.subscribe = watched  # type: ignore[method-assign,assignment]
    bridge = SerialBridge(bus, "t", "serial-test", port="loop://", spec=replace(chair_spec("chair"), id=asked))
    assert keys.control("t") in declared  # on building the bridge: before its serial thread can start
    bridge.host.add = add  # type: ignore[method-assign]
    rid = bridge.register()
    assert rid == bridge.robot_id == (asked or 9)
    assert declared[keys.control("t")] == (False, 0)
    assert declared[keys.actions("t", rid)] == (asked == 0, 0)


def test_an_e_stop_sent_before_the_chair_is_registered_acts_once_it_is() -> None:
    """What comes on world/control before the id is known waits: the chair's own e-stop latches
    once the id is set, another robot's never does."""
    bus = LocalBus(Inbox())
    bridge = SerialBridge(bus, "t", "serial-test", port="loop://", spec=replace(chair_spec("chair"), id=7))
    bridge.host.add = lambda agent, **_: 7  # type: ignore[method-assign]
    bus.publish(keys.control("t"), encode(Control(command="estop", robot_id=8)))
    bridge._inputs(0.0)  # not registered: nothing taken
    assert not bridge.core.estop
    bus.publish(keys.control("t"), encode(Control(command="estop", robot_id=7)))
    bridge.register()
    bridge._inputs(0.0)
    assert bridge.core.estop  # its own, sent before it was registered
    other = SerialBridge(LocalBus(Inbox()), "t", "serial-other", port="loop://", spec=replace(chair_spec("c"), id=9))
    other.host.add = lambda agent, **_: 9
    other.host.io.bus.publish(keys.control("t"), encode(Control(command="estop", robot_id=8)))
    other.register()
    other._inputs(0.0)
    assert not other.core.estop  # another robot's e-stop


def test_a_chair_registered_again_under_another_id_answers_to_that_id() -> None:
    """With no id asked, a chair the world removed and the host registered again may get another
    id (the host tells the agent: on_registered). The bridge then obeys that id's actions and
    e-stops, and its former id's no more: before, it kept its first id, and an operator's e-stop
    for the chair's new id was ignored."""
    bus = LocalBus(Inbox())
    bridge = SerialBridge(bus, "t", "serial-test", port="loop://", spec=replace(chair_spec("chair"), id=0))

    def add(agent: _Chair, **_: object) -> int:  # the world gives 3, and the host says so
        agent.on_registered(3, bridge.spec)
        return 3

    bridge.host.add = add  # type: ignore[assignment,method-assign]
    assert bridge.register() == 3
    _Chair(bridge).on_registered(5, bridge.spec)  # removed, registered again: robot 5
    assert bridge.robot_id == 5
    bus.publish(keys.actions("t", 3), encode(Actions(robot_id=3, left=0.1, right=0.1)))
    bridge._inputs(1.0)
    assert bridge.core.command == (0.0, 0.0)  # robot 3 is somebody else now
    bus.publish(keys.actions("t", 5), encode(Actions(robot_id=5, left=0.05, right=0.05)))
    bus.publish(keys.control("t"), encode(Control(command="estop", robot_id=5)))
    bridge._inputs(2.0)
    assert bridge.core.command == (0.05, 0.05)
    assert bridge.core.estop
