"""The options of ``iwz bridge ciberrato`` (``--sim``, ``--name``, ``-v`` and the network flags
are every role's: :func:`iw_zenoh.runtime.start_role`)."""

from __future__ import annotations

import argparse

__all__ = ["DESCRIPTION", "EPILOG", "add_arguments"]

DESCRIPTION = "Let unmodified Ciber-Rato / Intellwheels agents and viewers (XML/UDP) join a Zenoh simulation."
EPILOG = (
    "Example:\n"
    "iwz bridge ciberrato --param maps/ciberrato/C1-config.xml\n"
    "then start the legacy agents and viewers against UDP port 6000, unchanged."
)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The flags of ``iwz bridge ciberrato`` (after ``ciberrato``)."""
    p.add_argument("--port", type=int, default=6000, help="registration port (default 6000: unmodified clients use it)")
    p.add_argument(
        "--bind", default="127.0.0.1", help="address to listen on (default loopback only; 0.0.0.0 to open it)"
    )
    p.add_argument("--param", help="a Ciber-Rato parameters file (what clients are told: sensors on/off, noise)")
    p.add_argument(
        "--scoring",
        type=int,
        choices=[0, 1, 2, 3],
        default=0,
        help="the legacy --scoring: 0 competitive (default), 1 control (C1), 2 mapping, 3 planning (C2-C5); "
        "scores go to viewers, and in Measures when the parameters' ScoreSensor is On",
    )
    p.add_argument(
        "--pace",
        choices=["auto", "off"],
        default="auto",
        help="real-time worlds: send every Measures of a cycle at a steady offset from the cycle's start, "
        "learned from how late readings come (auto, default: one period between Measures as the legacy "
        "server keeps it); off: send each as soon as its readings arrive",
    )
