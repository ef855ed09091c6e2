"""Our own legacy clients for the bridge's integration tests (what croblink.py and the Qt viewer do
on the wire, :mod:`benchmarks.parity`, which ``benchmarks/c1_held.py`` shares) and a
ciberrato-profile world to talk to, and a busy process to run beside it."""

from __future__ import annotations

import contextlib
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

from benchmarks.parity import LegacyClient, measures_of, udp_port
from iw_zenoh import keys
from tests.integration.harness import MAPS, Net, wait_alive

__all__ = ["LegacyClient", "busy_cpu", "ciberrato_world", "measures_of", "udp_port"]


def ciberrato_world(
    net: Net,
    params: Path | None = MAPS / "ciberrato" / "C1-config.xml",
    *,
    lab: str | None = None,
    grid: str | None = None,
    radio: bool = False,
    bridge: tuple[str, ...] = (),
    world: tuple[str, ...] = (),
) -> int:
    """A ciberrato-profile world (C1's lab and grid unless given as XML text; ``world``: more of
    its flags) with collision, sensors and the bridge on a free UDP port (returned), each of them
    alive (a world that steps before its collision process is there holds its robots still)."""
    lab_path, grid_path = MAPS / "ciberrato" / "C1-lab.xml", MAPS / "ciberrato" / "C1-grid.xml"
    if lab is not None:
        lab_path = net.tmp / "lab.xml"
        lab_path.write_text(lab)
    if grid is not None:
        grid_path = net.tmp / "grid.xml"
        grid_path.write_text(grid)
    port = udp_port()
    net.spawn("world", str(lab_path), "--grid", str(grid_path), "--profile", "ciberrato", "--period-ms", "50", *world)
    net.spawn("collision")
    net.spawn("sensors")
    if radio:
        net.spawn("radio")
    net.spawn("bridge", "ciberrato", "--port", str(port), *(["--param", str(params)] if params else []), *bridge)
    bus = net.client()
    alive = [("collision", "collision"), ("sensors", "sensors-1-1"), ("bridge", "ciberrato")]
    for role, name in alive + ([("radio", "radio")] if radio else []):
        wait_alive(bus, keys.alive(net.sim, role, name))
    return port


@contextlib.contextmanager
def busy_cpu() -> Iterator[None]:
    """A process spinning on a core beside the run (a loaded machine), stopped by its pid after."""
    spin = subprocess.Popen([sys.executable, "-c", "while True: pass"], stdin=subprocess.DEVNULL)
    try:
        yield
    finally:
        spin.kill()
        spin.wait(timeout=10)
