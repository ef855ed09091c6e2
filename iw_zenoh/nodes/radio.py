"""``iwz radio``: robot-to-robot messages, delivered only within range (the logic and its limits:
:mod:`iw_zenoh.sim.radio`)."""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence

import msgspec

from iw_zenoh import keys
from iw_zenoh.bus import Bus
from iw_zenoh.errors import ProtocolError
from iw_zenoh.messages import Say, WorldState
from iw_zenoh.nodes.role_options import RadioOptions, add_radio_arguments
from iw_zenoh.options import options_from_args
from iw_zenoh.runtime import NodeIO, start_role
from iw_zenoh.sim.radio import RadioConfig, RadioNode
from iw_zenoh.ticks import TickWindow

__all__ = ["main", "run"]

logger = logging.getLogger(__name__)


def run(bus: Bus, sim: str, cfg: RadioConfig | None = None, *, name: str = "radio", io: NodeIO | None = None) -> None:
    """Delivers radio messages every tick until stopped."""
    io = io or NodeIO(bus, sim, "radio", name)
    says = io.inbox(keys.all_say(sim))
    states = io.inbox(keys.state(sim))
    node = RadioNode(sim, cfg)
    window = TickWindow()  # a state too far ahead is refused (its hear lists would be too)
    io.alive()
    while not io.stop.is_set():
        got = False
        for d in says.drain():
            got = True
            msg = io.decode(d, Say)
            if msg is not None and keys.robot_id_of(d[0]) != msg.robot_id:
                io.bad_message(d[0], ProtocolError(f"a message of robot {msg.robot_id} on another robot's key"))
            elif msg is not None:
                node.on_say(msg)
        for d in states.drain():
            got = True
            st = io.decode(d, WorldState)
            why = window.refuse(st.tick, time.monotonic_ns()) if st is not None else ""
            if why:
                io.bad_message(d[0], ProtocolError(why))
            elif st is not None:
                io.send_all(node.on_state(st))
        if not got:
            io.wait(0.2)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz radio``."""
    return start_role(
        argv,
        role="radio",
        description="Robot-to-robot messages, delivered only to robots within range.",
        epilog=(
            "Examples (a shorter range than Ciber-Rato's 8 m):\n"
            "  iwz radio --range 4\n"
            '  iwz radio --options \'{"range_m": 4, "max_heard_bytes": 200}\'    (as iwz run starts it)'
        ),
        arguments=add_radio_arguments,
        prepare=lambda args: RadioConfig(**msgspec.structs.asdict(options_from_args(args, RadioOptions))),
        run=lambda proc, cfg: run(proc.bus, proc.sim, cfg, io=proc.io),
    )
