"""Our own legacy clients for the bridge's integration tests: what croblink.py (a robot) and the
Qt viewer do on the wire, written from the fact sheet, and a ciberrato-profile world to talk to."""

from __future__ import annotations

import socket
from pathlib import Path

from lxml import etree

from iw_zenoh import keys
from tests.integration.harness import MAPS, Net, wait_alive

__all__ = ["LegacyClient", "ciberrato_world", "measures_of", "udp_port"]


def udp_port() -> int:
    """A free UDP port on loopback."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class LegacyClient:
    """What croblink.py does: register on the port, then talk to the port the reply came from."""

    def __init__(self, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(2.0)  # croblink's own timeout
        self.server = ("127.0.0.1", port)

    def register(self, xml: bytes, tries: int = 30) -> bytes:
        """Registers (asking again every 2 s while the bridge starts); the reply."""
        for _ in range(tries):  # the bridge may still be starting: ask again, as a user would
            self.sock.sendto(xml, self.server)
            try:
                data, addr = self.sock.recvfrom(1024)
            except TimeoutError:
                continue
            self.server = addr
            return data
        raise AssertionError("no reply to the registration")

    def recv(self, size: int = 4096) -> bytes:
        """The next datagram (croblink's 2 s timeout)."""
        data, _ = self.sock.recvfrom(size)  # 4096: croblink's Measures buffer
        return data

    def send(self, xml: bytes) -> None:
        """Sends to the client's own server socket."""
        self.sock.sendto(xml, self.server)

    def close(self) -> None:
        """Closes the socket."""
        self.sock.close()


def measures_of(data: bytes) -> etree._Element:
    """A Measures datagram as XML (its trailing NUL dropped)."""
    return etree.fromstring(data.rstrip(b"\x00"))


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
    for role, name in (("collision", "collision"), ("sensors", "sensors-1-1"), ("bridge", "ciberrato")):
        wait_alive(bus, keys.alive(net.sim, role, name))
    return port
