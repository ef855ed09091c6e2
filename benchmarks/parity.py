"""The parity trace's scripted legacy robot, shared by the parity test and ``benchmarks/c1_held.py``.

What croblink.py (a robot) and the Qt viewer do on the wire (:class:`LegacyClient`, written from
the fact sheet), the script of ``tests/data/legacy/README.md`` ("Parity trace": 4 IR sensors, the
command of phase ``(t // 40) % 4`` answering every Measures), and the rows compared with the legacy
simulator's own (:data:`REAL`). It lives here, not in ``tests/``, because benchmarks import no
test code; the tests import it from here.
"""

from __future__ import annotations

import json
import socket
import time
from pathlib import Path
from typing import Any

from lxml import etree

__all__ = [
    "PARAMS",
    "PHASES",
    "REAL",
    "ROBOT",
    "LegacyClient",
    "command",
    "displaced",
    "drive",
    "first_difference",
    "measures_of",
    "real_rows",
    "row",
    "udp_port",
]

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "legacy"
REAL = DATA / "parity_C1_nonoise.real.json"  # the legacy simulator's rows: 400 cycles, every noise 0
PARAMS = DATA / "parity_C1_nonoise.param.xml"
PHASES = ((0.1, 0.1), (0.05, 0.12), (-0.08, 0.08), (-0.06, -0.06))  # (left, right), 40 cycles each
ROBOT = (
    b'<Robot Id="1" Name="parity"><IRSensor Id="0" Angle="0.0" /><IRSensor Id="1" Angle="60.0" />'
    b'<IRSensor Id="2" Angle="-60.0" /><IRSensor Id="3" Angle="180.0" /></Robot>'
)

Row = dict[str, Any]


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
    """A Measures datagram as XML (its trailing NUL dropped; Latin-1, as the legacy server sends it)."""
    return etree.fromstring(data.rstrip(b"\x00"), etree.XMLParser(encoding="iso-8859-1"))


def real_rows() -> list[Row]:
    """The legacy simulator's rows (:data:`REAL`)."""
    rows: list[Row] = json.loads(REAL.read_text())["rows"]
    return rows


def command(t: int) -> bytes:
    """The script's Actions answering the Measures of Time ``t``."""
    left, right = PHASES[(t // 40) % 4]
    return f'<Actions LeftMotor="{left}" RightMotor="{right}"/>'.encode()


def row(m: etree._Element) -> Row:
    """A Measures as a row of the reference: t, GPS, compass, collision, the four IR values."""
    sensors = m.find("Sensors")
    gps = sensors.find("GPS")
    ir = {int(e.get("Id")): float(e.get("Value")) for e in sensors.findall("IRSensor")}
    return {
        "t": int(m.get("Time")),
        "x": float(gps.get("X")),
        "y": float(gps.get("Y")),
        "compass": float(sensors.get("Compass")),
        "collision": sensors.get("Collision") == "Yes",
        "ir": [ir[i] for i in range(4)],
    }


def displaced(rows: list[Row]) -> list[Row]:
    """GPS as displacement from the first fix (GPS offsets differ by design)."""
    x0, y0 = rows[0]["x"], rows[0]["y"]
    return [{**r, "x": round(r["x"] - x0, 1), "y": round(r["y"] - y0, 1)} for r in rows]


def first_difference(got: list[Row], want: list[Row]) -> tuple[int, Row | None, Row] | None:
    """Where ``got`` departs from ``want`` (both displaced), row by row of the same Time: how many
    of ``want``'s rows differ, and the first of them, ours (``None``: a Time ours lacks) and the
    reference's; ``None`` when every row is the same."""
    ours = {r["t"]: r for r in got}
    diff = [(ours.get(w["t"]), w) for w in want if ours.get(w["t"]) != w]
    return (len(diff), *diff[0]) if diff else None


def drive(robot: LegacyClient, viewer: LegacyClient, last_t: int, answered: dict[int, int] | None = None) -> list[Row]:
    """Runs the script: answers every Measures (those of Time 0, before Start, too), sends Start
    from the viewer right after the first answer (so the action is not overtaken), and returns the
    rows of Time 1 to ``last_t`` as received (a cycle the robot never heard is not there).
    ``answered`` is given each Time's first answer's wall clock (ns), when asked for."""
    rows: list[Row] = []
    started = False
    while not rows or rows[-1]["t"] < last_t:
        m = measures_of(robot.recv())
        t = int(m.get("Time"))
        robot.send(command(t))
        if answered is not None:
            answered.setdefault(t, time.time_ns())
        if not started:
            viewer.send(b"<Start/>\n\x00")
            started = True
        if t >= 1:
            rows.append(row(m))
    return rows
