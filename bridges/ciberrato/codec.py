"""The Ciber-Rato / Intellwheels wire protocol as pure functions: ``parse_*`` for what clients
send, ``build_*`` for what the server sends (fact sheet ``ciberrato-protocol.md``).

Framing: every datagram the server sends ends in exactly one NUL (after a newline); what clients
send may or may not carry one, and anything after the first NUL is ignored. Every input goes
through one hardened lxml parser; malformed input raises
:class:`~iw_zenoh.errors.ProtocolError` with the reason, never a half-parsed value.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field

from lxml import etree

from iw_zenoh.core.params import SimParameters
from iw_zenoh.core.spec import BodyShape, IrSensorSpec, NoiseSpec, RobotSpec, RobotType, SensorNoise
from iw_zenoh.errors import ProtocolError, SpecError

__all__ = [
    "ACTIONS_LIMIT",
    "REGISTRATION_LIMIT",
    "VIEWER_LIMIT",
    "ActionsFrame",
    "Measures",
    "Registration",
    "Score",
    "ViewerCommand",
    "build_measures",
    "build_refusal",
    "build_reply",
    "build_robot_state",
    "frame",
    "legacy_noise",
    "parse_actions",
    "parse_registration",
    "parse_viewer_command",
    "registration_spec",
]

REGISTRATION_LIMIT = 1023  # the legacy server reads at most this much on port 6000
ACTIONS_LIMIT = 1023  # ... and on a robot's own socket
VIEWER_LIMIT = 63  # ... and on a viewer's socket
SAY_MAX_CHARS = 100
LEGACY_IR_ANGLES = (0.0, 60.0, -60.0, 180.0)  # Ciber-Rato's default IR mounting angles
CIBER_RADIUS = 0.5


_PARSERS = threading.local()


def _parser() -> etree.XMLParser:
    """The hardened parser, one per thread (building one costs more than parsing an Actions)."""
    p: etree.XMLParser | None = getattr(_PARSERS, "parser", None)
    if p is None:
        p = _PARSERS.parser = etree.XMLParser(
            resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False, remove_comments=True
        )
    return p


def frame(datagram: bytes, limit: int) -> bytes:
    """The XML text of a datagram: refused past ``limit`` bytes, cut at the first NUL.

    Raises:
        ProtocolError: When it is longer than the legacy server would read, or empty.
    """
    if len(datagram) > limit + 1:  # one terminating NUL past the limit is how the C clients send
        raise ProtocolError(f"datagram of {len(datagram)} bytes is over the {limit}-byte limit")
    text = datagram.split(b"\x00", 1)[0]
    if not text.strip():
        raise ProtocolError("empty datagram")
    return text


_REGISTRATION_ROOTS = (b"<Robot", b"<RobotBeacon", b"<View", b"<Panel")
_AFTER_NAME = (b"", b" ", b"\t", b"\r", b"\n", b"/", b">")


def _root_is(text: bytes, roots: tuple[bytes, ...]) -> bool:
    """Whether the text can start with one of ``roots`` (a few byte comparisons, no parsing: most
    of a flood is refused here); a declaration or a DOCTYPE is left to the parser."""
    t = text.lstrip()
    if t.startswith((b"<?", b"<!")):
        return True
    return any(t.startswith(r) and t[len(r) : len(r) + 1] in _AFTER_NAME for r in roots)


def _xml(text: bytes) -> etree._Element:
    try:
        root = etree.fromstring(text, _parser())
    except etree.XMLSyntaxError as e:
        raise ProtocolError(f"not well-formed XML: {e.msg}") from None
    tree = root.getroottree()
    if tree.docinfo.internalDTD is not None or tree.docinfo.doctype:
        raise ProtocolError("DOCTYPE declarations are refused")
    return root


def _float(el: etree._Element, *names: str) -> float | None:
    for n in names:
        raw = el.get(n)
        if raw is None:
            continue
        try:
            v = float(raw)
        except ValueError:
            raise ProtocolError(f"<{el.tag}> {n}={raw!r} is not a number") from None
        if not math.isfinite(v):
            raise ProtocolError(f"<{el.tag}> {n}={raw!r} is not a finite number")
        return v
    return None


def _digits(raw: str | None, what: str) -> int | None:
    """A whole number written in ASCII digits (spaces around allowed); None when absent or not
    digits at all (the caller's legacy rule applies).

    Raises:
        ProtocolError: For digits that are not ASCII: ``str.isdigit()`` holds for "²" or "٣",
            which ``int()`` refuses or reads as another number than the legacy server would.
    """
    if raw is None:
        return None
    text = raw.strip()
    if not text.isdigit():
        return None
    if not text.isascii():
        raise ProtocolError(f"{what}={raw!r} is not written in ASCII digits")
    return int(text)


@dataclass(frozen=True)
class Registration:
    """A registration datagram on port 6000.

    Attributes:
        kind: ``robot``, ``beacon`` (RobotBeacon), ``view`` or ``panel``.
        name: Robot name.
        robot_id: Requested id (0: first free slot; a missing or bad Id counts as 0).
        beacon_height: A RobotBeacon's height.
        ir: IR sensors as (id, angle_deg, x, y, cone_deg) with None for what was not given.
        body: Intellwheels body attributes given (width, height, com, x, y, dir, max_speed,
            acceleration_curve), by canonical name.
        type: Intellwheels Type (Simulated, Real, Door), if given.
    """

    kind: str
    name: str = ""
    robot_id: int = 0
    beacon_height: float | None = None
    ir: tuple[tuple[int, float, float | None, float | None, float | None], ...] = ()
    body: dict[str, float] = field(default_factory=dict)
    type: str | None = None


_BODY_ATTRS = {
    "width": ("Width",),
    "height": ("Height", "Heigth"),
    "com": ("COM", "COMass", "CenterOfMovement"),
    "x": ("X",),
    "y": ("Y",),
    "dir": ("DIR", "Dir"),
    "max_speed": ("MaxSpeed",),
    "acceleration_curve": ("AccelerationCurve", "AccerelationCurve"),
}


def parse_registration(datagram: bytes) -> Registration:
    """Reads a datagram sent to port 6000.

    Raises:
        ProtocolError: Over the size limit, not XML, an unknown root or child element.
    """
    text = frame(datagram, REGISTRATION_LIMIT)
    if not _root_is(text, _REGISTRATION_ROOTS):
        raise ProtocolError(f"unknown registration {text[:16]!r}...; expected Robot, RobotBeacon, View or Panel")
    root = _xml(text)
    tag = root.tag
    if tag in ("View", "Panel"):
        if len(root):
            raise ProtocolError(f"<{tag}> takes no children")
        return Registration(kind=str(tag).lower())
    if tag not in ("Robot", "RobotBeacon"):
        raise ProtocolError(f"unknown registration <{tag}>; expected Robot, RobotBeacon, View or Panel")
    robot_id = _digits(root.get("Id"), "Id")
    robot_id = 0 if robot_id is None else robot_id  # legacy: a missing or bad Id means "any"
    ir: list[tuple[int, float, float | None, float | None, float | None]] = []
    for child in root:
        if not isinstance(child.tag, str):
            continue
        if child.tag != "IRSensor":
            raise ProtocolError(f"unknown element <{child.tag}> in <{tag}>")
        sid, angle = _digits(child.get("Id"), "IRSensor Id"), child.get("Angle")
        if sid is None or angle is None:
            continue  # the legacy server ignores an IRSensor without Id or Angle
        ir.append((sid, _float(child, "Angle") or 0.0, _float(child, "X"), _float(child, "Y"), _float(child, "Cone")))
    body = {k: v for k, names in _BODY_ATTRS.items() if (v := _float(root, *names)) is not None}
    return Registration(
        kind="beacon" if tag == "RobotBeacon" else "robot",
        name=root.get("Name", ""),
        robot_id=robot_id,
        beacon_height=_float(root, "Height") if tag == "RobotBeacon" else None,
        ir=tuple(ir),
        body=body if tag == "Robot" else {},
        type=root.get("Type"),
    )


def legacy_noise(p: SimParameters) -> SensorNoise:
    """The sensor noise a parameters file asks for (Table 3.1 quantities, per robot)."""

    def n(std: float) -> NoiseSpec:
        return NoiseSpec(0.0, std, enabled=std > 0)

    return SensorNoise(
        proximity_m=NoiseSpec(0.0, 0.0, enabled=False),
        proximity_legacy=n(p.obstacle_noise),
        compass_deg=n(p.compass_noise),
        beacon_deg=n(p.beacon_noise),
        gps_m=n(p.gps_lin_noise),
        gps_heading_deg=n(p.gps_dir_noise),
        encoder_slip=NoiseSpec(0.0, 0.0, enabled=False),
        motion=NoiseSpec(0.0, 0.0, enabled=False),  # MotorsNoise is the world's (--motors-noise)
    )


def registration_spec(reg: Registration, params: SimParameters | None = None) -> RobotSpec:
    """The robot a legacy registration asks for.

    A plain Ciber-Rato registration (no body attributes) is a disc of diameter 1 with four IR
    sensors on its rim at the given (or default) angles; an Intellwheels one is a rectangle with
    its fields, sensors where it placed them (Table 4.5's defaults when it placed none).

    Raises:
        SpecError: A field out of range, naming it.
    """
    name = (reg.name or f"robot{reg.robot_id}")[:20]
    noise = legacy_noise(params) if params is not None else SensorNoise()
    body = reg.body
    intellwheels = bool(body) or reg.type is not None or any(s[2] is not None for s in reg.ir)
    if not intellwheels:
        angles = dict(enumerate(LEGACY_IR_ANGLES))
        for sid, angle, *_ in reg.ir:
            if sid < len(LEGACY_IR_ANGLES):
                angles[sid] = angle
        sensors = tuple(
            IrSensorSpec(
                i, CIBER_RADIUS * math.cos(math.radians(a)), CIBER_RADIUS * math.sin(math.radians(a)), a, 60.0, 1e3
            )
            for i, a in sorted(angles.items())
        )
        return RobotSpec(
            name,
            id=reg.robot_id,
            shape=BodyShape.CIRCLE,
            ir_sensors=sensors,
            legacy=True,
            noise=noise,
            beacon_height_m=(reg.beacon_height or 0.0) if reg.kind == "beacon" else None,
        )
    try:
        rtype = RobotType(reg.type) if reg.type else RobotType.SIMULATED
    except ValueError:
        raise SpecError("Type", f"must be Simulated, Real or Door, got {reg.type!r}") from None
    sensors = tuple(
        IrSensorSpec(sid, x or 0.0, y or 0.0, angle, cone if cone is not None else 60.0)
        for sid, angle, x, y, cone in reg.ir
    )
    return RobotSpec(
        name,
        id=reg.robot_id,
        type=rtype,
        width_m=body.get("width", 1.0),
        height_m=body.get("height", 1.0),
        com=body.get("com", 0.5),
        x_m=body.get("x"),
        y_m=body.get("y"),
        dir_deg=body.get("dir"),
        max_speed_mps=body.get("max_speed", 0.5),
        acceleration_curve=body.get("acceleration_curve", 0.5),
        ir_sensors=sensors,
        legacy=True,
        noise=noise,
    )


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
    root = _xml(frame(datagram, ACTIONS_LIMIT))
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
        x, y, d = _float(root, "X"), _float(root, "Y"), _float(root, "DIR", "Dir")
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
    root = _xml(frame(datagram, VIEWER_LIMIT))
    simple = {"Start": "start", "Stop": "stop", "LabReq": "labreq", "GridReq": "gridreq"}
    if root.tag in simple:
        return ViewerCommand(simple[str(root.tag)])
    if root.tag == "Robot" and root.get("Removed") == "Yes":
        robot_id = _digits(root.get("Id"), "Id")
        if robot_id is not None:
            return ViewerCommand("remove", robot_id)
    raise ProtocolError(
        f'unknown viewer command <{root.tag}>; expected Start, Stop, LabReq, GridReq or Robot Id= Removed="Yes"'
    )


def _g(v: float) -> str:
    return f"{v:g}"


def _onoff(v: bool) -> str:
    return "On" if v else "Off"


def _finish(root: etree._Element) -> bytes:
    etree.indent(root, space="\t")
    return bytes(etree.tostring(root, encoding="utf-8")) + b"\n\x00"


def build_reply(
    p: SimParameters, *, n_beacons: int, lab_file: str | None = None, grid_file: str | None = None
) -> bytes:
    """The ``<Reply Status="Ok">`` every robot, viewer and panel gets (at most 1024 bytes)."""
    root = etree.Element("Reply", Status="Ok")
    attrs = {
        "SimTime": str(p.sim_time),
        "CycleTime": str(p.cycle_time_ms),
        "CompassNoise": _g(p.compass_noise),
        "BeaconNoise": _g(p.beacon_noise),
        "ObstacleNoise": _g(p.obstacle_noise),
        "MotorsNoise": _g(p.motors_noise),
        "KeyTime": str(p.key_time),
        "GPS": _onoff(p.gps),
        "GPSLinNoise": _g(p.gps_lin_noise),
        "GPSDirNoise": _g(p.gps_dir_noise),
        "BeaconSensor": _onoff(p.beacon_sensor),
        "CompassSensor": _onoff(p.compass_sensor),
        "ScoreSensor": _onoff(p.score_sensor),
        "ShowActions": "True" if p.show_actions else "False",
        "NBeacons": str(n_beacons),
        "NRequestsPerCycle": str(p.n_requests_per_cycle),
        "ObstacleRequestable": _onoff(p.obstacle_requestable),
        "BeaconRequestable": _onoff(p.beacon_requestable),
        "GroundRequestable": _onoff(p.ground_requestable),
        "CompassRequestable": _onoff(p.compass_requestable),
        "CollisionRequestable": _onoff(p.collision_requestable),
        "ObstacleLatency": str(p.obstacle_latency),
        "BeaconLatency": str(p.beacon_latency),
        "GroundLatency": str(p.ground_latency),
        "CompassLatency": str(p.compass_latency),
        "CollisionLatency": str(p.collision_latency),
        "BeaconAperture": f"{p.beacon_aperture_rad:f}",
        "ReturnTimePenalty": str(p.return_time_penalty),
        "ArrivalTimePenalty": str(p.arrival_time_penalty),
        "CollisionWallPenalty": str(p.collision_wall_penalty),
        "CollisionRobotPenalty": str(p.collision_robot_penalty),
        "TargetReward": str(p.target_reward),
        "HomeReward": str(p.home_reward),
    }
    params = etree.SubElement(root, "Parameters")
    for k, v in attrs.items():
        params.set(k, v)
    for k, path in (("Lab", lab_file), ("Grid", grid_file)):
        if path is not None:
            params.set(k, path)
    data = _finish(root)
    if len(data) > 1024 and (lab_file or grid_file):
        return build_reply(p, n_beacons=n_beacons)  # long file names would not fit the clients' 1024 bytes
    return data


def build_refusal() -> bytes:
    """``<Reply Status="Refused"></Reply>`` and its terminator."""
    root = etree.Element("Reply", Status="Refused")
    root.text = ""
    return bytes(etree.tostring(root, encoding="utf-8")) + b"\n\x00"


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
    """A ``<Measures>`` datagram, byte for byte as the legacy server prints it (at most 4096 bytes
    for the Python and C clients): tab indents, ``<GPS ... />`` with its space, ``\\n\\0`` at
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
        safe = text.encode("latin-1", "replace").decode("latin-1").replace("]]>", "]] >")  # CDATA cannot hold ]]>
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
        f'\t</Sensors>\n\t<Leds EndLed="{_onoff(end)}" ReturningLed="{_onoff(ret)}" VisitingLed="{_onoff(vis)}"/>\n'
        f'\t<Buttons Start="{_onoff(start)}" Stop="{_onoff(stop)}"/>\n</Measures>\n\x00'
    )
    return "".join(out).encode("utf-8")


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
    etree.SubElement(root, "Position", X=_g(x), Y=_g(y), Dir=_g(dir_deg))
    return _finish(root)
