"""A simulation for a serial bridge to join: its world, collision and sensors started on the test's router."""

from __future__ import annotations

from iw_zenoh.bus import ZenohBus
from tests.integration.harness import MAPS, Net


def start_sim(net: Net, link: str) -> ZenohBus:
    """World, collision, sensors and the serial bridge for robot 1 on ``link``."""
    net.spawn("world", str(MAPS / "liacc.xml"), "--grid", str(MAPS / "liacc-grid.xml"))
    net.spawn("collision")
    net.spawn("sensors")
    net.spawn(
        "bridge",
        "serial",
        "--port",
        link,
        "--robot",
        "chair",
        "--id",
        "1",
        "--start",
        "10,6.1,0",
        "--log",
        str(net.tmp / "bridge.csv"),
    )
    return net.client()
