"""Command-line arguments every process shares: which simulation, how to join the bus, logging."""

from __future__ import annotations

import argparse

from iw_zenoh.bus.net import DEFAULT_ENDPOINT, DEFAULT_TLS_ENDPOINT, NetConfig

__all__ = ["add_common_arguments", "add_zenoh_arguments", "net_from_args"]


def add_zenoh_arguments(parser: argparse.ArgumentParser, *, default_mode: str = "client") -> None:
    """Adds ``--mode --connect --listen --lan --zenoh-config --identity --cfg`` (as zenoh-python's examples)."""
    g = parser.add_argument_group("network (default: client of the router on " + DEFAULT_ENDPOINT + ", loopback only)")
    g.add_argument(
        "--mode",
        choices=["client", "peer", "router"],
        default=default_mode,
        help=f"Zenoh session mode (default {default_mode})",
    )
    g.add_argument(
        "-e",
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="endpoint to connect to, e.g. tcp/10.0.0.5:7447 (repeatable)",
    )
    g.add_argument(
        "-l",
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable)",
    )
    g.add_argument(
        "--lan",
        action="store_true",
        help="turn multicast scouting on, to find peers on the LAN without naming a router",
    )
    g.add_argument(
        "--zenoh-config",
        metavar="FILE",
        help="a Zenoh JSON5 configuration file: its values stand unless a flag here says otherwise "
        "(each value a flag replaces is reported); the built-in defaults fill only what it leaves out",
    )
    g.add_argument(
        "--identity",
        metavar="DIR/NAME",
        help="join over mutual TLS as the identity NAME (DIR/NAME.crt, DIR/NAME.key, DIR/ca.crt, made by "
        "iwz secure): TLS only, no scouting; default endpoint " + DEFAULT_TLS_ENDPOINT,
    )
    g.add_argument(
        "--cfg",
        action="append",
        default=[],
        metavar="KEY:VALUE",
        help="a Zenoh configuration override, e.g. transport/link/tx/lease:5000",
    )


def add_common_arguments(parser: argparse.ArgumentParser, *, default_mode: str = "client") -> None:
    """Adds ``--sim``, ``-v`` and the network arguments."""
    parser.add_argument(
        "--sim", default="default", help="simulation name: every key lives under iw/SIM/ (default: default)"
    )
    parser.add_argument("-v", "--verbose", action="count", default=0, help="log more (-v info, -vv debug)")
    add_zenoh_arguments(parser, default_mode=default_mode)


def net_from_args(args: argparse.Namespace) -> NetConfig:
    """The network configuration the arguments ask for."""
    return NetConfig(
        mode=args.mode,
        connect=tuple(args.connect),
        listen=tuple(args.listen),
        lan=bool(args.lan),
        config_file=args.zenoh_config,
        overrides=tuple(args.cfg),
        identity=getattr(args, "identity", None),
        policy=getattr(args, "security_policy", None),  # the router's --policy
    )
