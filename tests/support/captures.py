"""Reading the golden legacy captures of ``tests/data/legacy/`` (real legacy traffic, byte for
byte): one datagram a line, ``TIME DIR SRC->DST len=N b'...'``."""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

from lxml import etree

from iw_zenoh.core.params import SimParameters
from iw_zenoh.maps import parse_parameters

LEGACY = Path(__file__).parent.parent / "data" / "legacy"


@dataclass(frozen=True)
class Datagram:
    """One captured datagram."""

    t: float
    to_server: bool
    src: int
    dst: int
    data: bytes


def read(name: str) -> list[Datagram]:
    """Every datagram of a capture, in order."""
    out = []
    for line in (LEGACY / name).read_text().splitlines():
        t, direction, ports, _, literal = line.split(" ", 4)
        src, dst = ports.split("->")
        data = ast.literal_eval(literal)
        assert isinstance(data, bytes)
        out.append(Datagram(float(t), direction == "C->S", int(src), int(dst), data))
    return out


def robot_session(name: str) -> tuple[SimParameters, int, list[Datagram]]:
    """The first robot's session of a capture: the parameters and NBeacons its reply gave, and
    every datagram between it and its own server socket (Actions in, Measures out) in order."""
    grams = read(name)
    reg = next(g for g in grams if g.to_server and g.dst == 6000 and g.data.startswith(b"<Robot "))
    reply = next(g for g in grams if not g.to_server and g.dst == reg.src and g.data.startswith(b"<Reply"))
    root = etree.fromstring(reply.data.rstrip(b"\x00"))
    params_el = root.find("Parameters")
    assert params_el is not None
    params = parse_parameters(etree.tostring(params_el))
    session = [g for g in grams if {g.src, g.dst} == {reg.src, reply.src} and g.t > reply.t]
    return params, int(params_el.get("NBeacons", "0")), session
