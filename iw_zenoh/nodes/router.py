"""``iwz router``: the Zenoh router every other process connects to (no zenohd binary needed).

Default: listens on tcp/127.0.0.1:7447 only, multicast scouting off. For several laptops:
``iwz router --listen tcp/0.0.0.0:7447`` on one, ``--connect tcp/HOST:7447`` on the others.
"""

from __future__ import annotations

import argparse
import logging
from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.cliargs import add_common_arguments, net_from_args
from iw_zenoh.errors import IwError
from iw_zenoh.nodes.base import NodeIO, install_stop_signals, setup_logging

__all__ = ["main"]

logger = logging.getLogger(__name__)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz router`` until Ctrl-C or SIGTERM."""
    p = argparse.ArgumentParser(
        prog="iwz router",
        description="A Zenoh router for the simulation's processes (loopback only unless --listen says otherwise).",
        epilog="Example (serve a LAN): iwz router --listen tcp/0.0.0.0:7447",
    )
    p.add_argument("--name", default="router", help="instance name (liveliness)")
    add_common_arguments(p, default_mode="router")
    args = p.parse_args(argv)
    setup_logging(args.verbose, "router")
    try:
        bus = ZenohBus(net_from_args(args))
    except (IwError, ValueError) as e:
        print(f"iwz router: {e}")
        return 2
    except Exception as e:  # zenoh's own error when the port is taken
        print(
            f"iwz router: cannot open the router: {e}; is another router on that port? Use --listen tcp/127.0.0.1:PORT"
        )
        return 2
    io = NodeIO(bus, keys.chunk(args.sim), "router", args.name)
    io.alive()
    install_stop_signals(io.stop, io.wake.set)
    print(f"iwz router: listening on {', '.join(bus.net.listen) or 'tcp/127.0.0.1:7447'}", flush=True)
    try:
        while not io.stop.is_set():
            io.stop.wait(1.0)
    finally:
        bus.close()
    return 0
