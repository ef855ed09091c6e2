"""The flags of ``iwz bridge ciberrato``, each filling a field of its options
(:class:`~iw_zenoh.nodes.role_options.BridgeOptions`, declared beside the other roles' so that
``iwz run`` builds them without importing the bridge); ``--sim``, ``--name``, ``-v`` and the
network flags are every role's (:func:`iw_zenoh.process.runtime.start_role`)."""

from __future__ import annotations

import argparse

from iw_zenoh.nodes.role_options import BridgeOptions
from iw_zenoh.process.options import Flag, add_option_flags

__all__ = ["DESCRIPTION", "EPILOG", "BridgeOptions", "add_arguments"]

DESCRIPTION = "Let unmodified Ciber-Rato / Intellwheels agents and viewers (XML/UDP) join a Zenoh simulation."
EPILOG = (
    "Examples:\n"
    "iwz bridge ciberrato --param maps/ciberrato/C1-config.xml\n"
    "then start the legacy agents and viewers against UDP port 6000, unchanged.\n"
    'iwz bridge ciberrato --options \'{"port": 6000, "scoring": 1}\'    (as iwz run starts it)'
)


_FLAGS: tuple[Flag, ...] = (
    (
        "--port",
        "port",
        {"type": int, "metavar": "PORT"},
        "registration port (default {default}: unmodified clients use it)",
    ),
    ("--bind", "bind", {"metavar": "ADDRESS"}, "address to listen on (default loopback only; 0.0.0.0 to open it)"),
    (
        "--param",
        "param",
        {"metavar": "FILE"},
        "a Ciber-Rato parameters file (what clients are told: sensors on/off, noise)",
    ),
    (
        "--scoring",
        "scoring",
        {"type": int, "choices": [0, 1, 2, 3]},
        "the legacy --scoring: 0 competitive (default), 1 control (C1), 2 mapping, 3 planning (C2-C5); "
        "scores go to viewers, and in Measures when the parameters' ScoreSensor is On",
    ),
    (
        "--pace",
        "pace",
        {"choices": ["auto", "off"]},
        "real-time worlds: send every Measures of a cycle at a steady offset from the cycle's start, "
        "learned from how late readings come (auto, default: one period between Measures as the legacy "
        "server keeps it); off: send each as soon as its readings arrive",
    ),
)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The flags of ``iwz bridge ciberrato`` (after ``ciberrato``), each filling a field of
    :class:`BridgeOptions`, and ``--options JSON``."""
    add_option_flags(p, BridgeOptions, _FLAGS)
