"""The arguments of ``iwz run`` and where it records by default."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

__all__ = ["build_parser", "default_recording"]


def default_recording(name: str) -> Path:
    """``recordings/NAME-DATE-TIME.mcap``."""
    return Path("recordings") / f"{name}-{time.strftime('%Y%m%d-%H%M%S')}.mcap"


def build_parser() -> argparse.ArgumentParser:
    """The arguments of ``iwz run``."""
    p = argparse.ArgumentParser(
        prog="iwz run",
        description=(
            "Start a whole simulation from a scenario file: the router, world, collision, sensors, "
            "radio and every agent, each its own process on this machine."
        ),
        epilog="Example: iwz run maps/demo.toml    (Ctrl-C stops everything cleanly)",
    )
    p.add_argument("scenario", help="scenario TOML file (see docs/scenarios.md)")
    p.add_argument(
        "--port", type=int, default=0, help="router port on 127.0.0.1 (default 7447, or a free port if taken)"
    )
    p.add_argument("--sim", default="default", help="simulation name (default: default)")
    p.add_argument("--log-dir", help="where each process's log goes (default: a new temporary folder)")
    p.add_argument("--no-status", action="store_true", help="no live status line")
    p.add_argument("--record", metavar="FILE", help="record the run here (default recordings/SCENARIO-DATE-TIME.mcap)")
    p.add_argument("--no-record", action="store_true", help="do not record the run")
    p.add_argument("--lockstep", action="store_true", help="run in lock-step whatever the scenario says (reproducible)")
    p.add_argument("-v", "--verbose", action="count", default=0, help="log more")
    return p
