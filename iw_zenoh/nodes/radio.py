"""``iwz radio``: robot-to-robot messages, delivered only within range (the logic and its limits:
:mod:`iw_zenoh.sim.radio`)."""

from __future__ import annotations

import argparse
import logging
from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.bus import Bus, ZenohBus
from iw_zenoh.cliargs import add_common_arguments, net_from_args
from iw_zenoh.errors import IwError
from iw_zenoh.messages import Say, WorldState
from iw_zenoh.nodes.base import NodeIO, install_stop_signals, setup_logging
from iw_zenoh.sim.radio import RadioConfig, RadioNode

__all__ = ["main", "run"]

logger = logging.getLogger(__name__)


def run(bus: Bus, sim: str, cfg: RadioConfig | None = None, *, name: str = "radio", io: NodeIO | None = None) -> None:
    """Delivers radio messages every tick until stopped."""
    io = io or NodeIO(bus, sim, "radio", name)
    says = io.inbox(keys.all_say(sim))
    states = io.inbox(keys.state(sim))
    node = RadioNode(sim, cfg)
    io.alive()
    while not io.stop.is_set():
        got = False
        for d in says.drain():
            got = True
            msg = io.decode(d, Say)
            if msg is not None and keys.robot_id_of(d[0]) == msg.robot_id:
                node.on_say(msg)
        for d in states.drain():
            got = True
            st = io.decode(d, WorldState)
            if st is not None:
                io.send_all(node.on_state(st))
        if not got:
            io.wait(0.2)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz radio``."""
    p = argparse.ArgumentParser(
        prog="iwz radio", description="Robot-to-robot messages, delivered only to robots within range."
    )
    p.add_argument("--range", type=float, default=8.0, help="delivery range in metres (default 8)")
    p.add_argument(
        "--max-bytes", type=int, default=100, help="longest message in bytes; longer ones are dropped (default 100)"
    )
    p.add_argument("--budget", type=int, default=400, help="bytes a robot hears per tick at most (default 400)")
    p.add_argument("--name", default="radio", help="instance name (liveliness)")
    add_common_arguments(p)
    args = p.parse_args(argv)
    setup_logging(args.verbose, "radio")
    try:
        if args.range <= 0 or args.max_bytes <= 0 or args.budget <= 0:
            raise ValueError("--range, --max-bytes and --budget must be > 0")
        bus = ZenohBus(net_from_args(args))
    except (IwError, ValueError) as e:
        print(f"iwz radio: {e}")
        return 2
    io = NodeIO(bus, keys.chunk(args.sim), "radio", args.name)
    install_stop_signals(io.stop, io.wake.set)
    try:
        run(bus, args.sim, RadioConfig(args.range, args.max_bytes, args.budget), io=io)
    finally:
        bus.close()
    return 0
