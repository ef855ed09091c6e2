"""The Ciber-Rato / Intellwheels wire protocol of every cycle as pure functions: ``parse_*`` for
what robots and viewers send, ``build_*`` for what the server sends them (fact sheet
``ciberrato-protocol.md``). Registration on port 6000 is :mod:`.registration`'s; framing and the
hardened parser are :mod:`.xmlwire`'s.

Framing: every datagram the server sends ends in exactly one NUL (after a newline); what clients
send may or may not carry one, and anything after the first NUL is ignored. Every input goes
through one hardened lxml parser; malformed input raises
:class:`~iw_zenoh.errors.ProtocolError` with the reason, never a half-parsed value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from lxml import etree

from iw_zenoh.errors import ProtocolError

from .xmlwire import digits, finish, float_attr, fmt_g, frame, onoff, parse_xml

__all__ = [
    "ACTIONS_LIMIT",
    "VIEWER_LIMIT",
    "ActionsFrame",
    "Measures",
    "Score",
    "ViewerCommand",
    "build_measures",
    "build_robot_state",
    "parse_actions",
    "parse_viewer_command",
]

ACTIONS_LIMIT = 1023  # the legacy server reads at most this much on a robot's own socket
VIEWER_LIMIT = 63  # ... and on a viewer's socket
SAY_MAX_CHARS = 100


@dataclass(frozen=True)
class ActionsFrame:
    """What one actions datagram says; ``None`` for what it does not mention (motors are sticky).

    Attributes:
        left: Left motor power as received (the world clamps).
        right: Right motor power.
        leds: LEDs mentioned, on only for exactly ``On``.
        requests: Sensor request names (``IRSensor0``, ``Compass``...), in order, duplicates kept.
        say: A radio message, or None (longer than 100 characters: dropped, as the legacy server does).
        pose: (x, y, dir_deg) from a Real robot, or None.
    """

    left: float | None = None
    right: float | None = None
    leds: dict[str, bool] = field(default_factory=dict)
    requests: tuple[str, ...] = ()
    say: str | None = None
    pose: tuple[float, float, float] | None = None


def _motor(el: etree._Element, name: str) -> float | None:
    raw = el.get(name)
    if raw is None:
        return None
    try:
        v = float(raw)
    except ValueError:
        return 0.0  # legacy: a motor value that does not parse counts as 0
    return v if math.isfinite(v) else 0.0


def parse_actions(datagram: bytes) -> ActionsFrame:
    """Reads a datagram a robot sends to its own socket.

    Raises:
        ProtocolError: Over the size limit, not XML, or an element other than Actions,
            SensorRequests or Say (the whole datagram is then ignored, as in the legacy server).
    """
    root = parse_xml(frame(datagram, ACTIONS_LIMIT))
    allowed = ("Actions", "SensorRequests", "Say")
    for el in root.iter():
        if isinstance(el.tag, str) and el.tag not in allowed:
            raise ProtocolError(f"unknown element <{el.tag}> in actions")
    leds: dict[str, bool] = {}
    left = right = None
    pose = None
    if root.tag == "Actions":
        left, right = _motor(root, "LeftMotor"), _motor(root, "RightMotor")
        for led in ("EndLed", "ReturningLed", "VisitingLed"):
            if root.get(led) is not None:
                leds[led] = root.get(led) == "On"
        x, y, d = float_attr(root, "X"), float_attr(root, "Y"), float_attr(root, "DIR", "Dir")
        if x is not None and y is not None:
            pose = (x, y, d or 0.0)
    requests: list[str] = []
    say: str | None = None
    for el in root.iter("SensorRequests", "Say"):
        if el.tag == "SensorRequests":
            requests += [k for k, v in el.attrib.items() if v == "Yes"]
        else:
            text = (el.text or "") + (
                el.tail if el.tail and not el.tail.strip() else ""
            )  # legacy quirk: trailing white space
            if len(text) <= SAY_MAX_CHARS:
                say = text
    return ActionsFrame(left, right, leds, tuple(requests), say, pose)


@dataclass(frozen=True)
class ViewerCommand:
    """A viewer's command: start, stop, labreq, gridreq or remove (with the robot id)."""

    kind: str
    robot_id: int = 0


def parse_viewer_command(datagram: bytes) -> ViewerCommand:
    """Reads a datagram a viewer sends to its own socket.

    Raises:
        ProtocolError: Over 63 bytes, not XML, or not one of the documented commands.
    """
    root = parse_xml(frame(datagram, VIEWER_LIMIT))
    simple = {"Start": "start", "Stop": "stop", "LabReq": "labreq", "GridReq": "gridreq"}
    if root.tag in simple:
        return ViewerCommand(simple[str(root.tag)])
    if root.tag == "Robot" and root.get("Removed") == "Yes":
        robot_id = digits(root.get("Id"), "Id")
        if robot_id is not None:
            return ViewerCommand("remove", robot_id)
    raise ProtocolError(
        f'unknown viewer command <{root.tag}>; expected Start, Stop, LabReq, GridReq or Robot Id= Removed="Yes"'
    )


@dataclass(frozen=True)
class Score:
    """A robot's ``<Score>`` (sent when the parameters' ScoreSensor is On)."""

    score: int
    arrival_time: int = 0
    returning_time: int = 0
    collisions: int = 0
    collision: bool = False
    visited_mask: str = ""


@dataclass(frozen=True)
class Measures:
    """One robot's ``<Measures>`` of a cycle; None leaves an element out."""

    time: int
    collision: bool | None = None
    compass: float | None = None
    ground: int | None = None
    ir: tuple[float | None, ...] = ()  # None: not sent this cycle (requestable, not requested)
    beacons: tuple[float | None, ...] | None = None
    gps: tuple[float, float] | None = None
    messages: tuple[tuple[int, str], ...] = ()
    leds: tuple[bool, bool, bool] = (False, False, False)
    buttons: tuple[bool, bool] = (False, True)
    score: Score | None = None


def build_measures(m: Measures) -> bytes:
    r"""A ``<Measures>`` datagram, byte for byte as the legacy server prints it (at most 4096 bytes
    for the Python and C clients), in Latin-1: tab indents, ``<GPS ... />`` with its space, ``\n\0`` at
    the end. Formatted directly rather than through lxml: it is sent to every robot every cycle."""
    attrs = ""
    if m.collision is not None:
        attrs += f' Collision="{"Yes" if m.collision else "No"}"'
    if m.compass is not None:
        attrs += f' Compass="{m.compass:g}"'
    if m.ground is not None:
        attrs += f' Ground="{m.ground:d}"'
    out = [f'<Measures Time="{m.time:d}">\n\t<Sensors{attrs}>\n']
    for i, v in enumerate(m.ir):
        if v is not None:
            out.append(f'\t\t<IRSensor Id="{i}" Value="{v:g}"/>\n')
    for i, b in enumerate(m.beacons or ()):
        out.append(f'\t\t<BeaconSensor Id="{i}" Value="{"NotVisible" if b is None else format(b, "g")}"/>\n')
    if m.gps is not None:
        out.append(f'\t\t<GPS X="{m.gps[0]:g}" Y="{m.gps[1]:g}" />\n')
    for sender, text in m.messages:
        safe = text.replace("]]>", "]] >")  # CDATA cannot hold ]]>
        out.append(f'\t\t<Message From="{sender:d}"><![CDATA[{safe}]]></Message>\n')
    if m.score is not None:
        sc = m.score
        out.append(
            f'\t\t<Score Score="{sc.score:d}" ArrivalTime="{sc.arrival_time:d}" '
            f'ReturningTime="{sc.returning_time:d}" Collisions="{sc.collisions:d}" '
            f'Collision="{"True" if sc.collision else "False"}" VisitedMask="{sc.visited_mask}" />\n'
        )
    end, ret, vis = m.leds
    start, stop = m.buttons
    out.append(
        f'\t</Sensors>\n\t<Leds EndLed="{onoff(end)}" ReturningLed="{onoff(ret)}" VisitingLed="{onoff(vis)}"/>\n'
        f'\t<Buttons Start="{onoff(start)}" Stop="{onoff(stop)}"/>\n</Measures>\n\x00'
    )
    # Latin-1, as the legacy server sends it: a heard "é" is the one byte E9, and what Latin-1
    # cannot hold is "?" (everything else here is ASCII)
    return "".join(out).encode("latin-1", "replace")


def build_robot_state(
    *,
    name: str,
    robot_id: int,
    time: int,
    x: float,
    y: float,
    dir_deg: float,
    collisions: int = 0,
    collision: bool = False,
    state: str = "Running",
    score: int = 0,
    arrival_time: int | None = None,
    returning_time: int = 0,
    visited_mask: str = "000",
) -> bytes:
    """The per-cycle ``<Robot>`` datagram for viewers (``%u`` numbers: a negative score wraps)."""
    root = etree.Element("Robot")
    for k, v in (
        ("Name", name[:24]),
        ("Id", str(robot_id)),
        ("Time", str(time)),
        ("Score", str(score & 0xFFFFFFFF)),
        ("ArrivalTime", str((time if arrival_time is None else arrival_time) & 0xFFFFFFFF)),
        ("ReturningTime", str(returning_time & 0xFFFFFFFF)),
        ("Collisions", str(collisions)),
        ("Collision", "True" if collision else "False"),
        ("VisitedMask", visited_mask),
        ("State", state),
    ):
        root.set(k, v)
    etree.SubElement(root, "Position", X=fmt_g(x), Y=fmt_g(y), Dir=fmt_g(dir_deg))
    return finish(root)
