"""The serial bridge's registration, against the serial loop that runs beside it."""

from __future__ import annotations

from bridges.serial.board import chair_spec
from bridges.serial.node import SerialBridge
from iw_zenoh import keys
from iw_zenoh.bus import Inbox
from iw_zenoh.viewer.sources import LocalBus


def test_the_control_inbox_is_declared_before_any_reading_can_go_out() -> None:
    """The serial loop publishes the chair's readings as soon as ``robot_id`` is set. Set before
    the control inbox was declared, an operator who saw the first reading and pressed e-stop at
    once lost it (CI caught it: no e-stop in 5 s). Every inbox must exist before the id does."""
    bridge = SerialBridge(LocalBus(Inbox()), "t", "serial-test", port="loop://", spec=chair_spec("chair"))
    bridge.host.add = lambda agent, **_: 7  # type: ignore[method-assign]  # the world's answer
    seen: list[tuple[str, int]] = []
    inbox = bridge.host.io.inbox

    def declare(key: str, *args: object, **kwargs: object) -> Inbox:
        seen.append((key, bridge.robot_id))
        return inbox(key, *args, **kwargs)  # type: ignore[arg-type]

    bridge.host.io.inbox = declare  # type: ignore[method-assign,assignment]
    assert bridge.register() == 7
    assert bridge.robot_id == 7
    assert sorted(seen) == sorted([(keys.actions("t", 7), 0), (keys.control("t"), 0)])
