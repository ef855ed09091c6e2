"""``iwz router``: the Zenoh router every other process connects to (no zenohd binary needed).

Default: listens on tcp/127.0.0.1:7447 only, multicast scouting off. For several laptops:
``iwz router --listen tcp/0.0.0.0:7447`` on one, ``--connect tcp/HOST:7447`` on the others.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

from iw_zenoh.runtime import Process, start_role

__all__ = ["main"]

logger = logging.getLogger(__name__)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz router`` until Ctrl-C or SIGTERM."""
    return start_role(
        argv,
        role="router",
        description="A Zenoh router for the simulation's processes (loopback only unless --listen says otherwise).",
        epilog="Example (serve a LAN):\n  iwz router --listen tcp/0.0.0.0:7447",
        run=_serve,
        default_mode="router",
    )


def _serve(proc: Process) -> None:
    proc.io.alive()
    print(f"iwz router: listening on {', '.join(proc.bus.net.listen) or 'tcp/127.0.0.1:7447'}", flush=True)
    while not proc.io.stop.is_set():
        proc.io.stop.wait(1.0)
