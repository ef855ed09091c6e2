"""``iwz bridge ciberrato``: the command (the bridge itself is :class:`~.node.Bridge`)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.core.params import SimParameters
from iw_zenoh.errors import IwError
from iw_zenoh.maps import load_parameters
from iw_zenoh.nodes.role_options import BridgeOptions
from iw_zenoh.process.options import options_from_args
from iw_zenoh.process.runtime import Process, start_role

from .node import Bridge
from .options import DESCRIPTION, EPILOG, add_arguments
from .scoring import Mode
from .transport import PortTaken, UdpTransport, udp_factory

__all__ = ["main"]

PROG = "iwz bridge ciberrato"


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz bridge ciberrato``: 2 when it cannot start (its UDP port taken: by whom)."""
    args_in = list(argv or [])
    if args_in[:1] != ["ciberrato"]:
        print(f"usage: {PROG} [options]   ({PROG} --help)")
        return 2 if args_in[:1] not in (["-h"], ["--help"]) else 0
    return start_role(
        args_in[1:],
        role="bridge",
        prog=PROG,
        description=DESCRIPTION,
        epilog=EPILOG,
        arguments=add_arguments,
        prepare=_prepare,
        run=_run,
        name=lambda args: "ciberrato",
        name_help="ciberrato",
    )


def _prepare(args: argparse.Namespace) -> tuple[BridgeOptions, UdpTransport, SimParameters]:
    """The options, the registration port, bound before joining the bus (a taken one: who has
    it), and the legacy parameters."""
    opts = options_from_args(args, BridgeOptions)
    try:
        reception = UdpTransport(opts.bind, opts.port)
    except PortTaken as e:
        raise IwError(
            f"cannot listen on UDP {opts.bind}:{opts.port}: the port is taken by "
            f"{e.owner or 'another socket'}; stop it, or give this bridge another --port"
        ) from None
    except OSError as e:
        raise IwError(f"cannot listen on UDP {opts.bind}:{opts.port}: {e.strerror}") from None
    try:
        return opts, reception, load_parameters(opts.param) if opts.param else SimParameters()
    except (IwError, ValueError):
        reception.close()
        raise


def _run(proc: Process, prepared: tuple[BridgeOptions, UdpTransport, SimParameters]) -> int:
    opts, reception, params = prepared
    bridge = Bridge(
        proc.bus,
        proc.sim,
        reception,
        new_transport=udp_factory(opts.bind),
        params=params,
        name=keys.chunk(proc.name),
        scoring=Mode(opts.scoring),
        pace=opts.pace == "auto",
    )
    proc.on_stop(bridge.io.stop.set)
    print(f"{PROG}: listening on udp {opts.bind}:{reception.port} for iw/{proc.sim}/", flush=True)
    try:
        bridge.serve()
    finally:
        bridge.close()
    return 0
