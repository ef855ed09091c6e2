"""``iwz bridge ciberrato``: the command (the bridge itself is :class:`~.node.Bridge`)."""

from __future__ import annotations

from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.cliargs import net_from_args
from iw_zenoh.core.params import SimParameters
from iw_zenoh.errors import IwError
from iw_zenoh.maps import load_parameters
from iw_zenoh.runtime import install_stop_signals, setup_logging

from .node import Bridge
from .options import parser
from .scoring import Mode
from .transport import PortTaken, UdpTransport, udp_factory

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz bridge ciberrato``: 2 when it cannot start (its UDP port taken: by whom)."""
    args_in = list(argv or [])
    if args_in[:1] != ["ciberrato"]:
        print("usage: iwz bridge ciberrato [options]   (iwz bridge ciberrato --help)")
        return 2 if args_in[:1] not in (["-h"], ["--help"]) else 0
    args = parser().parse_args(args_in[1:])
    setup_logging(args.verbose, "bridge")
    try:
        reception = UdpTransport(args.bind, args.port)
    except PortTaken as e:
        print(
            f"iwz bridge ciberrato: cannot listen on UDP {args.bind}:{args.port}: the port is taken by "
            f"{e.owner or 'another socket'}; stop it, or give this bridge another --port"
        )
        return 2
    except OSError as e:
        print(f"iwz bridge ciberrato: cannot listen on UDP {args.bind}:{args.port}: {e.strerror}")
        return 2
    try:
        params = load_parameters(args.param) if args.param else SimParameters()
        bus = ZenohBus(net_from_args(args))
    except (IwError, ValueError) as e:
        reception.close()
        print(f"iwz bridge ciberrato: {e}")
        return 2
    bridge = Bridge(
        bus,
        keys.chunk(args.sim),
        reception,
        new_transport=udp_factory(args.bind),
        params=params,
        name=keys.chunk(args.name),
        scoring=Mode(args.scoring),
        pace=args.pace == "auto",
    )
    install_stop_signals(bridge.io.stop)
    print(f"iwz bridge ciberrato: listening on udp {args.bind}:{reception.port} for iw/{args.sim}/", flush=True)
    try:
        bridge.serve()
    finally:
        bridge.close()
        bus.close()
    return 0
