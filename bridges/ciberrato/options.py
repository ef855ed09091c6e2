"""The options of ``iwz bridge ciberrato``."""

from __future__ import annotations

import argparse

from iw_zenoh.cliargs import add_common_arguments

__all__ = ["parser"]


def parser() -> argparse.ArgumentParser:
    """The command line of ``iwz bridge ciberrato`` (after ``ciberrato``)."""
    p = argparse.ArgumentParser(
        prog="iwz bridge ciberrato",
        description="Let unmodified Ciber-Rato / Intellwheels agents and viewers (XML/UDP) join a Zenoh simulation.",
        epilog=(
            "Example: iwz bridge ciberrato --param maps/ciberrato/C1-config.xml\n"
            "then start the legacy agents and viewers against UDP port 6000, unchanged."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
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
    p.add_argument("--name", default="ciberrato", help="process name (liveliness)")
    add_common_arguments(p)
    return p
