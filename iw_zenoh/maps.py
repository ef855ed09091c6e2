"""Reading and writing map files: Ciber-Rato / Intellwheels Lab XML, Grid XML and parameters.

The writers live in :mod:`iw_zenoh.map_writer` and are re-exported here.

One hardened lxml parser reads everything (no entities, no DTD, no network, no huge trees). A
broken file is refused with :class:`~iw_zenoh.errors.MapError` naming the file, the line, the
element and the reason; nothing is guessed.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import fields
from pathlib import Path

import shapely
from lxml import etree

from iw_zenoh.core.lab import Beacon, Grid, GridPosition, Lab, Target, Wall, check_wall
from iw_zenoh.core.params import SimParameters
from iw_zenoh.errors import MapError
from iw_zenoh.map_writer import grid_to_xml, lab_to_xml

__all__ = [
    "MAX_MAP_BYTES",
    "check_grid",
    "grid_to_xml",
    "lab_to_xml",
    "load_grid",
    "load_lab",
    "load_parameters",
    "parse_grid",
    "parse_lab",
    "parse_parameters",
    "parse_xml",
    "row_walls",
]

MAX_MAP_BYTES = 4 * 1024 * 1024  # far above any real map; refuses accidental huge files
LAB_MAX_M = 10_000.0  # a lab wider or longer than 10 km is a mistake (and past what the grid arithmetic takes)
ROW_WALL_HALF = 0.1  # Ciber-Rato row walls are 0.2 thick
ROW_LAST_COLUMN = 39  # Ciber-Rato hard-wires the last column of a 14-cell-wide lab


def _parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False, remove_comments=True
    )


def parse_xml(data: bytes, source: str) -> etree._Element:
    """Parses XML with the project's hardened parser.

    Args:
        data: The document.
        source: Its name, for errors.

    Returns:
        The root element.

    Raises:
        MapError: When it is not well-formed, or declares a DTD or entities.
    """
    if len(data) > MAX_MAP_BYTES:
        raise MapError(source, None, "document", f"{len(data)} bytes is over the {MAX_MAP_BYTES}-byte limit")
    try:
        root = etree.fromstring(data, _parser())
    except etree.XMLSyntaxError as e:
        line = e.lineno if isinstance(e.lineno, int) else None
        raise MapError(source, line, "document", f"not well-formed XML: {e.msg}") from None
    tree = root.getroottree()
    if tree.docinfo.internalDTD is not None or tree.docinfo.doctype:
        raise MapError(source, 1, "document", "DOCTYPE declarations are refused (entity tricks); remove it")
    return root


def _num(el: etree._Element, attr: str, source: str, default: float | None = None) -> float:
    raw = el.get(attr)
    if raw is None:
        if default is None:
            raise MapError(source, el.sourceline, str(el.tag), f"attribute {attr} is required")
        return default
    try:
        v = float(raw)
    except ValueError:
        raise MapError(source, el.sourceline, str(el.tag), f"attribute {attr}={raw!r} is not a number") from None
    if not math.isfinite(v):
        raise MapError(source, el.sourceline, str(el.tag), f"attribute {attr}={raw!r} is not a finite number")
    return v


def _element_name(el: etree._Element) -> str | None:
    return el.tag if isinstance(el.tag, str) else None


def _only(parent: etree._Element, tag: str, source: str) -> Iterator[etree._Element]:
    """``parent``'s elements (comments skipped), each a ``<tag>``, or a MapError at the first that is not."""
    for el in parent:
        name = _element_name(el)
        if name is None:
            continue
        if name != tag:
            raise MapError(source, el.sourceline, name, f"a <{parent.tag}> holds only <{tag}> elements")
        yield el


def row_walls(pos: int, pattern: str, height_m: float = 4.0) -> list[Wall]:
    """Turns one Ciber-Rato ``<Row>`` into walls, exactly as the legacy parser does.

    Args:
        pos: Row index (even: a cell row with ``|`` walls; odd: a line of ``-`` walls).
        pattern: The row's characters (columns count characters, not bytes).
        height_m: Height of the walls made.

    Returns:
        The walls, as rectangles.
    """

    def rect(x0: float, x1: float, y0: float, y1: float) -> Wall:
        return Wall(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), height_m)

    walls: list[Wall] = []
    if pos % 2 == 0:
        for c, ch in enumerate(pattern):
            if ch == "|":
                x = 2.0 * (c + 1) / 3.0
                walls.append(rect(x - ROW_WALL_HALF, x + ROW_WALL_HALF, float(pos), float(pos + 2)))
        return walls
    y = pos + 1.0
    start: int | None = None
    for c in range(0, len(pattern), 3):
        ch = pattern[c]
        if ch == "-":
            if start is None:
                start = c
            if c == ROW_LAST_COLUMN:
                walls.append(rect(2.0 * start / 3.0, 2.0 * (c / 3.0 + 1.0), y - ROW_WALL_HALF, y + ROW_WALL_HALF))
                start = None
        elif ch == " " and start is not None:
            e = c - 3
            walls.append(rect(2.0 * start / 3.0, 2.0 * (e / 3.0 + 1.0), y - ROW_WALL_HALF, y + ROW_WALL_HALF))
            start = None
    return walls  # a wall still open here is lost, as in the legacy parser


def _inside(el: etree._Element, x: float, y: float, source: str, width: float, height: float) -> None:
    """Refuses a point of ``el`` outside the ``width`` x ``height`` lab."""
    if not (0.0 <= x <= width and 0.0 <= y <= height):
        raise MapError(
            source, el.sourceline, str(el.tag), f"({x:g}, {y:g}) is outside the lab (0..{width:g} x 0..{height:g})"
        )


def _beacon(el: etree._Element, source: str, width: float, height: float) -> Beacon:
    """A ``<Beacon>`` (X, Y, Height 0 by default), inside the lab."""
    b = Beacon(_num(el, "X", source), _num(el, "Y", source), _num(el, "Height", source, 0.0))
    _inside(el, b.x, b.y, source, width, height)
    return b


def _target(el: etree._Element, source: str, width: float, height: float) -> Target:
    """A ``<Target>`` (X, Y, Radius > 0, 2 by default), its centre inside the lab."""
    r = _num(el, "Radius", source, 2.0)
    if r <= 0:
        raise MapError(source, el.sourceline, str(el.tag), f"Radius must be > 0, got {r:g}")
    t = Target(_num(el, "X", source), _num(el, "Y", source), r)
    _inside(el, t.x, t.y, source, width, height)
    return t


def _wall(el: etree._Element, source: str, width: float, height: float) -> Wall:
    """A ``<Wall>`` of ``<Corner>`` elements (Height 4 by default), a valid polygon in the lab."""
    h = _num(el, "Height", source, 4.0)
    corners: list[tuple[float, float]] = []
    for c in _only(el, "Corner", source):
        corners.append((_num(c, "X", source), _num(c, "Y", source)))
    reason = check_wall(tuple(corners), width, height)
    if reason:
        raise MapError(source, el.sourceline, str(el.tag), reason)
    return Wall(tuple(corners), h)


def _row(el: etree._Element, source: str, width: float, height: float) -> list[Wall]:
    """The walls of a Ciber-Rato ``<Row>`` (Pos, Pattern; see :func:`row_walls`), all in the lab."""
    pos_raw = el.get("Pos")
    pattern = el.get("Pattern")
    if pos_raw is None or pattern is None:
        raise MapError(source, el.sourceline, str(el.tag), "a <Row> needs Pos and Pattern attributes")
    try:
        pos = int(pos_raw)
    except ValueError:
        raise MapError(source, el.sourceline, str(el.tag), f"Pos={pos_raw!r} is not an integer") from None
    walls = row_walls(pos, pattern)
    for w in walls:
        reason = check_wall(w.corners, width, height)
        if reason:
            raise MapError(source, el.sourceline, str(el.tag), reason)
    return walls


def parse_lab(data: bytes, source: str = "<bytes>") -> Lab:
    """Reads a Lab document.

    Args:
        data: The XML.
        source: Its name, for errors.

    Returns:
        The lab.

    Raises:
        MapError: For any broken part: not XML, wrong root, a non-number, a wall with fewer
            than three corners, a self-intersecting wall, a wall outside the lab, a beacon or
            target outside it, an unknown element.
    """
    root = parse_xml(data, source)
    if root.tag != "Lab":
        raise MapError(source, root.sourceline, str(root.tag), "the root element of a lab file must be <Lab>")
    width = _num(root, "Width", source, 16.0)
    height = _num(root, "Height", source, 16.0)
    if not (0 < width <= LAB_MAX_M and 0 < height <= LAB_MAX_M):
        raise MapError(
            source,
            root.sourceline,
            "Lab",
            f"Width and Height must be > 0 and <= {LAB_MAX_M:g} m, got {width:g} x {height:g}",
        )
    walls: list[Wall] = []
    beacons: list[Beacon] = []
    targets: list[Target] = []
    for el in root:
        tag = _element_name(el)
        if tag is None:
            continue
        if tag == "Beacon":
            beacons.append(_beacon(el, source, width, height))
        elif tag == "Target":
            targets.append(_target(el, source, width, height))
        elif tag == "Wall":
            walls.append(_wall(el, source, width, height))
        elif tag == "Row":
            walls.extend(_row(el, source, width, height))
        else:
            raise MapError(source, el.sourceline, tag, "unknown element in a lab; expected Beacon, Target, Wall or Row")
    return Lab(root.get("Name", "NO NAMED LAB"), width, height, tuple(walls), tuple(beacons), tuple(targets))


def parse_grid(data: bytes, source: str = "<bytes>") -> Grid:
    """Reads a Grid document (start poses, X/Y in metres and Dir in degrees).

    Raises:
        MapError: For a wrong root, an unknown element, a non-number or a Dir out of range.
    """
    root = parse_xml(data, source)
    if root.tag != "Grid":
        raise MapError(source, root.sourceline, str(root.tag), "the root element of a grid file must be <Grid>")
    out: list[GridPosition] = []
    for el in _only(root, "Position", source):
        d = _num(el, "Dir", source, 0.0)
        if not -180.0 <= d <= 180.0:
            raise MapError(source, el.sourceline, "Position", f"Dir={d:g} must be in [-180, 180]")
        out.append(GridPosition(_num(el, "X", source, 0.0), _num(el, "Y", source, 0.0), d))
    return Grid(tuple(out))


def check_grid(lab: Lab, grid: Grid, source: str = "<grid>") -> None:
    """Refuses a grid whose positions are outside the lab or inside a wall.

    Raises:
        MapError: Naming the position (1-based, as robot ids count) and the wall.
    """
    polys = [shapely.Polygon(w.corners) for w in lab.walls]
    for k, p in enumerate(grid.positions, start=1):
        if not (0.0 < p.x < lab.width_m and 0.0 < p.y < lab.height_m):
            raise MapError(source, None, "Position", f"position {k} ({p.x:g}, {p.y:g}) is outside the lab {lab.name!r}")
        pt = shapely.Point(p.x, p.y)
        for i, poly in enumerate(polys):
            if poly.covers(pt):
                raise MapError(
                    source, None, "Position", f"position {k} ({p.x:g}, {p.y:g}) is inside wall {i} of lab {lab.name!r}"
                )


_PARAM_ATTRS: dict[str, str] = {
    "SimTime": "sim_time",
    "CycleTime": "cycle_time_ms",
    "KeyTime": "key_time",
    "CompassNoise": "compass_noise",
    "BeaconNoise": "beacon_noise",
    "ObstacleNoise": "obstacle_noise",
    "MotorsNoise": "motors_noise",
    "GPS": "gps",
    "GPSLinNoise": "gps_lin_noise",
    "GPSDirNoise": "gps_dir_noise",
    "BeaconSensor": "beacon_sensor",
    "CompassSensor": "compass_sensor",
    "ScoreSensor": "score_sensor",
    "NRequestsPerCycle": "n_requests_per_cycle",
    "ObstacleRequestable": "obstacle_requestable",
    "BeaconRequestable": "beacon_requestable",
    "GroundRequestable": "ground_requestable",
    "CompassRequestable": "compass_requestable",
    "CollisionRequestable": "collision_requestable",
    "ObstacleLatency": "obstacle_latency",
    "BeaconLatency": "beacon_latency",
    "GroundLatency": "ground_latency",
    "CompassLatency": "compass_latency",
    "collisionLatency": "collision_latency",  # sic: the legacy parser reads the lower-case c
    "BeaconAperture": "beacon_aperture_rad",
    "ReturnTimePenalty": "return_time_penalty",
    "ArrivalTimePenalty": "arrival_time_penalty",
    "CollisionWallPenalty": "collision_wall_penalty",
    "CollisionRobotPenalty": "collision_robot_penalty",
    "TargetReward": "target_reward",
    "HomeReward": "home_reward",
    "Lab": "lab_file",
    "Grid": "grid_file",
}


def parse_parameters(data: bytes, source: str = "<bytes>") -> SimParameters:
    """Reads a Ciber-Rato parameters file; attributes not given keep the built-in defaults.

    As in the legacy simulator, ``ShowActions``, ``NBeacons``, ``RequestsPerCycle`` and
    ``CollisionLatency`` (capital C) are not read, and an On/Off flag is on only for ``On``.

    Raises:
        MapError: For a wrong root, a non-number, or a negative count.
    """
    root = parse_xml(data, source)
    if root.tag != "Parameters":
        raise MapError(
            source, root.sourceline, str(root.tag), "the root element of a parameters file must be <Parameters>"
        )
    kinds = {f.name: f.type for f in fields(SimParameters)}
    values: dict[str, object] = {}
    for attr, name in _PARAM_ATTRS.items():
        raw = root.get(attr)
        if raw is None:
            continue
        kind = str(kinds[name])
        if kind == "bool":
            values[name] = raw == "On"
        elif kind.startswith("str"):
            values[name] = raw
        elif kind == "int":
            try:
                iv = int(raw)
            except ValueError:
                raise MapError(source, root.sourceline, "Parameters", f"{attr}={raw!r} is not an integer") from None
            if iv < 0 and attr not in ("CollisionWallPenalty", "CollisionRobotPenalty"):
                raise MapError(source, root.sourceline, "Parameters", f"{attr}={raw!r} must be >= 0")
            values[name] = iv
        else:
            fv = _num(root, attr, source)
            if fv < 0:
                raise MapError(source, root.sourceline, "Parameters", f"{attr}={raw!r} must be >= 0")
            values[name] = fv
    if values.get("cycle_time_ms", 1) == 0:
        raise MapError(source, root.sourceline, "Parameters", "CycleTime must be > 0 ms")
    return SimParameters(**values)  # type: ignore[arg-type]


def _read(path: str | Path) -> tuple[bytes, str]:
    p = Path(path)
    try:
        size = p.stat().st_size
        if size > MAX_MAP_BYTES:
            raise MapError(str(p), None, "document", f"{size} bytes is over the {MAX_MAP_BYTES}-byte limit")
        return p.read_bytes(), str(p)
    except OSError as e:
        raise MapError(str(p), None, "document", f"cannot read it: {e.strerror}") from None


def load_lab(path: str | Path) -> Lab:
    """Reads a Lab file. See :func:`parse_lab`."""
    return parse_lab(*_read(path))


def load_grid(path: str | Path, lab: Lab | None = None) -> Grid:
    """Reads a Grid file and, given its lab, refuses positions inside walls. See :func:`parse_grid`."""
    data, src = _read(path)
    grid = parse_grid(data, src)
    if lab is not None:
        check_grid(lab, grid, src)
    return grid


def load_parameters(path: str | Path) -> SimParameters:
    """Reads a parameters file. See :func:`parse_parameters`."""
    return parse_parameters(*_read(path))
