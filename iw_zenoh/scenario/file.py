"""Scenario files (TOML): what ``iwz run`` starts and how it judges the run.

A scenario names the map, grid, mode, period, seed and duration; the robots' agent programs with
their arguments; obstacles; and success criteria. Its tables are the msgspec Structs below: each
field's name, type, range and default is declared once, there, and msgspec decodes the TOML into
them. A bad scenario is refused with :class:`~iw_zenoh.errors.ConfigError` naming the file, the
field (``agents[0].robots``) and the reason. Paths are relative to the scenario file. See
``docs/scenarios.md`` for every field.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import stat
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

import msgspec
import numpy as np

from iw_zenoh.core.modes import Mode
from iw_zenoh.errors import ConfigError, MapError
from iw_zenoh.maps import load_grid, load_lab
from iw_zenoh.messages import Obstacle
from iw_zenoh.scenario.fields import apply_sets
from iw_zenoh.scenario.refused import args_table, at_line, old_names, room_table, start_table
from iw_zenoh.scenario.specfile import SPEC_TABLE, check_spec, line_of, load_spec_file, renamed_field
from iw_zenoh.sim.config import WorldSettings
from iw_zenoh.sim.obstacles import Obstacles

__all__ = [
    "AgentEntry",
    "BridgeSection",
    "ChairSection",
    "Criteria",
    "DoorCriterion",
    "ObstacleEntry",
    "Reach",
    "RolesSection",
    "Scenario",
    "ScenarioFile",
    "SecuritySection",
    "Start",
    "WorldSection",
    "load_scenario",
    "parse_scenario",
]

ObstacleEntry = Obstacle  # a scenario's obstacle is the very message the world is sent
Arg = str | int | float  # an argument as TOML writes it; handed on as its text

# the ranges of docs/scenarios.md, checked when the file is read (before anything starts)
SEED_MAX = 2**64 - 1  # numpy's seeds are 64-bit here
ID_MAX = 2**63 - 1  # a robot id: 63 bits
DURATION_S_MAX = 7 * 86_400.0  # a week of simulated time
ROBOTS_MAX = 1000  # robots one agent process registers
EXTENT_M = 10_000.0  # any coordinate or length, m (obstacles, goals, doorways)
DEPTH_MAX = 16  # tables and arrays nested deeper are refused (no scenario needs more than 4)
NAME = r"^([A-Za-z0-9][A-Za-z0-9._-]{0,63})?$"  # a name safe for a file name: a log, a recording
Name = Annotated[str, msgspec.Meta(pattern=NAME)]
Coord = Annotated[float, msgspec.Meta(ge=-EXTENT_M, le=EXTENT_M)]


class WorldSection(WorldSettings, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[world]``: the map and how the world runs: :class:`~iw_zenoh.sim.config.WorldSettings`
    (each of ``iwz world``'s options a typed field, declared there once) and what a scenario adds."""

    map: Path
    grid: Path | None = None
    duration_s: Annotated[float, msgspec.Meta(gt=0, le=DURATION_S_MAX)] = 60.0
    expect: Annotated[int, msgspec.Meta(ge=0, le=ID_MAX)] | None = None  # None: the robots the agents register
    args: tuple[Arg, ...] = ()  # refused (the argv of before): the fields above say it typed (refused.args_table)


class RolesSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[roles]``: which roles run beside the world, and how many."""

    sensors_shards: Annotated[int, msgspec.Meta(ge=1)] = 1  # at most the cores (checked on reading)
    radio: bool = True


class AgentEntry(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[[agents]]``: one agent process: a program of ``iw_zenoh.agents``, or the user's own file
    (``./my_agent.py[:Name]``, relative to the scenario), and its arguments."""

    program: str
    args: tuple[Arg, ...] = ()
    robots: Annotated[int, msgspec.Meta(ge=0, le=ROBOTS_MAX)] = 1
    name: Name = ""
    # its robots' spec as data (docs/spec.md): a table of the registration's fields, or a spec
    # file's path; read and checked when the scenario is, then handed to the agent as a table
    spec: dict[str, Any] | str | None = None
    seed: Annotated[int, msgspec.Meta(ge=0)] | None = None  # its agents' args.seed; None: drawn from [world] seed

    @property
    def argv(self) -> list[str]:
        """``args`` as a command line takes them."""
        return [str(a) for a in self.args]


class Reach(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[[criteria.reach]]``: robot ``robot`` must come within ``within_m`` metres of (``x_m``, ``y_m``)."""

    robot: Annotated[int, msgspec.Meta(ge=0, le=ID_MAX)]
    x_m: Coord
    y_m: Coord
    within_m: Annotated[float, msgspec.Meta(gt=0, le=EXTENT_M)] = 0.5


class DoorCriterion(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[[criteria.doors]]``: what door ``robot`` must do (``iw_zenoh/sim/doorwatch.py`` judges it).

    Its pose when first seen is its closed pose. It opened once it moved ``OPEN_M`` or turned
    ``OPEN_DEG`` from there; it is closed again when back within ``SHUT_M`` and ``SHUT_DEG`` (its
    heading taken modulo ``symmetry_deg``: a four-wing revolving door looks shut every 90 degrees).
    """

    robot: Annotated[int, msgspec.Meta(ge=0, le=ID_MAX)]
    opened: bool = True
    closed_again: bool = True
    x_m: Coord | None = None
    y_m: Coord | None = None
    one_chair_within_m: Annotated[float, msgspec.Meta(gt=0, le=EXTENT_M)] | None = None
    symmetry_deg: Annotated[float, msgspec.Meta(gt=0, le=360)] = 360.0


class Criteria(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[criteria]``: what makes a run a success."""

    max_collisions: Annotated[int, msgspec.Meta(ge=0, le=ID_MAX)] | None = None
    reach: tuple[Reach, ...] = ()
    doors: tuple[DoorCriterion, ...] = ()
    stop_when_reached: bool = True


class BridgeSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[bridge]``: a legacy XML/UDP bridge (Ciber-Rato) beside the world."""

    port: Annotated[int, msgspec.Meta(ge=1, le=65535)] = 6000
    params: Path | None = None
    scoring: Literal[0, 1, 2, 3] = 0


class Start(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[chair] start = { x_m = 1.5, y_m = 3.0, dir_deg = 0.0 }``: where a chair starts."""

    x_m: Coord = 1.0
    y_m: Coord = 1.0
    dir_deg: Annotated[float, msgspec.Meta(ge=-180.0, le=180.0)] = 0.0

    @property
    def arg(self) -> str:
        """As a command line takes it (``--start x,y,dir_deg``)."""
        return f"{self.x_m!r},{self.y_m!r},{self.dir_deg!r}"


class RoomBox(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[chair] room = [{ x0_m = 8.2, y0_m = 3.4, x1_m = 8.8, y1_m = 5.0 }]``: a box of an emulated chair's room."""

    x0_m: Coord
    y0_m: Coord
    x1_m: Coord
    y1_m: Coord

    @property
    def arg(self) -> str:
        """As a command line takes it (``--room x0,y0,x1,y1;...``, one part)."""
        return f"{self.x0_m!r},{self.y0_m!r},{self.x1_m!r},{self.y1_m!r}"


class ChairSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[chair]``: a real chair on a serial link (``docs/serial.md``): ``iwz bridge serial``, and
    without a ``port`` the chair emulator on a pseudo-terminal. The world must run in real time."""

    hardware: Literal["serial"] = "serial"
    port: str = ""  # the chair's device or pyserial URL; "": `iwz chair emulate --pty` stands in
    robot: Annotated[int, msgspec.Meta(ge=1, le=ID_MAX)] = 1  # the robot id the bridge registers
    name: Name = "chair"
    start: Start | str = msgspec.field(default_factory=Start)  # a string ("1,1,0", as before) is refused: a table
    room: tuple[RoomBox, ...] | str = ()  # emulator: real obstacles not in the map; a string (as before) is refused
    seed: Annotated[int, msgspec.Meta(ge=0)] = 0  # emulator: noise seed, 64 bits at most (_numbers)
    baud: Annotated[int, msgspec.Meta(gt=0, le=10_000_000)] = 115200
    spec: Path | None = None  # a spec file (docs/spec.md) the bridge and the emulator both read


class Ros2Section(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[ros2]``: how the chairs of ``[[agents]]`` entries with ``program = "ros2"`` (each run by
    ``iwz ros2``) meet a ROS 2 stack (docs/ros2.md)."""

    domain_id: Annotated[int, msgspec.Meta(ge=0, le=232)] = 0  # ROS_DOMAIN_ID
    namespace: str = "/robot{id}"  # each chair's namespace; {id} is its robot id
    stamped: bool = False  # cmd_vel is geometry_msgs/TwistStamped (else Twist)


class SecuritySection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[security]``: run every role with an identity of its own (docs/security.md), and where.

    ``hosts`` maps a host's name to the processes it runs (``world``, ``collision``,
    ``sensors-1``, ``recorder``, an agent's name...); ``iwz run --host NAME`` starts only those.
    A process no host names runs on the router's host (the one started without ``--host``).
    ``audit = false`` starts the router with ``--no-audit``: the policy is still enforced, but
    refusals go unreported (the router then reads no per-message log; docs/security.md has the cost).
    """

    enabled: bool = True
    hosts: dict[str, list[str]] = {}
    audit: bool = True


class ScenarioFile(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A scenario file's tables, as written (paths still relative to the file)."""

    world: WorldSection
    name: Name = ""
    roles: RolesSection = msgspec.field(default_factory=RolesSection)
    agents: tuple[AgentEntry, ...] = ()
    obstacles: tuple[Obstacle, ...] = ()
    criteria: Criteria = msgspec.field(default_factory=Criteria)
    bridge: BridgeSection | None = None
    chair: ChairSection | None = None
    security: SecuritySection | None = None
    ros2: Ros2Section = msgspec.field(default_factory=Ros2Section)


class Scenario(ScenarioFile, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A whole run: the file's tables with paths resolved, and the folder it came from.

    Attributes:
        base: The scenario's folder: agents run there, so their file arguments are relative to it.
    """

    base: Path = Path(".")

    @property
    def robots(self) -> int:
        """Robots the agents register in all."""
        return sum(a.robots for a in self.agents)

    def agent_seed(self, index: int) -> int:
        """The seed ``agents[index]`` is handed (``--seed``, its agents' ``args.seed``): the entry's
        own ``seed``, else the ``index``-th child of ``[world] seed`` (``np.random.SeedSequence``), so
        every entry's differs and the world's seed changes them all, the same every run.

        Args:
            index: The entry's place in ``agents``.

        Returns:
            A seed in [0, 2**32).
        """
        own = self.agents[index].seed
        if own is not None:
            return own
        return int(np.random.SeedSequence(self.world.seed, spawn_key=(index,)).generate_state(1)[0])


def _dec_path(kind: type, value: Any) -> Any:
    if kind is Path:
        if isinstance(value, str):
            return Path(value)
        raise ValueError(f"Expected `str` (a path), got `{type(value).__name__}`")
    raise NotImplementedError(kind)


_AT = re.compile(r"^(?P<reason>.*?)(?: - at `\$(?P<path>[^`]*)`)?$", re.DOTALL)
_NAMED = re.compile(r"Object (?:missing required|contains unknown) field `(?P<field>[^`]+)`")


def _value_at(doc: Any, path: str) -> Any:
    """The value at a msgspec path (``agents[0].robots``) of the decoded TOML."""
    for key, index in re.findall(r"\.?([^.\[\]]+)|\[(\d+)\]", path):
        doc = doc[int(index)] if index else doc[key]
    return doc


def _refusal(error: msgspec.ValidationError, doc: dict[str, Any], name: str) -> ConfigError:
    """A msgspec validation error as a ConfigError: the field's dotted path (``agents[0].robots``) and the reason."""
    m = _AT.match(str(error))
    assert m is not None  # the pattern matches any text
    reason, path = m["reason"], (m["path"] or "").lstrip(".")
    named = _NAMED.match(reason)
    if NAME in reason:  # msgspec would show the regex
        got = _value_at(doc, path)
        shown = repr(got) if len(repr(got)) <= 40 else f"{repr(got)[:37]}...' ({len(got)} characters)"
        reason = f"must be 1 to 64 letters, digits, '.', '_' or '-', from a letter or digit (names files), got {shown}"
    elif named:
        path = f"{path}.{named['field']}" if path else named["field"]
        reason = "is required" if "missing" in reason else "unknown field"
    elif "got" not in reason and "value" not in reason:
        with contextlib.suppress(KeyError, IndexError, TypeError, ValueError):  # else the reason stands alone
            reason = f"{reason}, got {_value_at(doc, path)!r}"
    if not re.search(r"[.\[]", path):  # a top-level field is named after the scenario
        path = f"{name}.{path}" if path else name
    return ConfigError(path, reason)


def _exists(path: Path | None, where: str) -> None:
    """Refuses a path that is not a regular file this process can read, saying what it is instead."""
    if path is None:
        return
    try:
        mode = path.stat().st_mode
    except OSError as e:
        what = "does not exist" if isinstance(e, FileNotFoundError) else f"cannot be read ({e.strerror})"
        raise ConfigError(where, f"{path} {what}") from None
    if stat.S_ISDIR(mode):
        raise ConfigError(where, f"{path} is a directory: name a file")
    if not stat.S_ISREG(mode):
        kind = (
            "a FIFO" if stat.S_ISFIFO(mode) else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a socket"
        )
        raise ConfigError(where, f"{path} is {kind}, not a regular file: name a file")
    if not os.access(path, os.R_OK):
        raise ConfigError(where, f"{path} cannot be read (permission denied)")


def _numbers(value: Any, path: str = "", depth: int = 0) -> None:
    """Refuses nesting deeper than :data:`DEPTH_MAX`, and any number not finite or beyond 64 bits,
    anywhere in the decoded TOML (``args`` and ``spec`` tables included), naming where."""
    if depth > DEPTH_MAX:
        raise ConfigError(path or "scenario", f"nested more than {DEPTH_MAX} tables or arrays deep")
    if isinstance(value, dict):
        for k, v in value.items():
            _numbers(v, f"{path}.{k}" if path else str(k), depth + 1)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _numbers(v, f"{path}[{i}]", depth + 1)
    elif isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(path, f"must be a finite number, got {value!r}")
    elif isinstance(value, int) and not isinstance(value, bool) and not -(2**63) <= value <= SEED_MAX:
        raise ConfigError(path, f"must fit in 64 bits, got a number of {len(str(abs(value)))} digits")


def _toml(text: str, name: str) -> dict[str, Any]:
    """The TOML decoded, its numbers and nesting checked (:func:`_numbers`)."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(name, f"not valid TOML: {e}") from None
    except RecursionError:
        raise ConfigError(name, f"nested more than {DEPTH_MAX} tables or arrays deep") from None
    try:
        _numbers(doc)
    except ConfigError as e:
        if not re.search(r"[.\[]", e.field):  # a top-level field is named after the scenario
            raise ConfigError(f"{name}.{e.field}", e.reason) from None
        raise
    return doc


def _check_ranges(sc: ScenarioFile) -> None:
    """The ranges no field's type says: shards within the cores, obstacles within the extent."""
    cores = max(2, os.cpu_count() or 1)
    if sc.roles.sensors_shards > cores:
        raise ConfigError("roles.sensors_shards", f"at most the machine's {cores} cores, got {sc.roles.sensors_shards}")
    for i, o in enumerate(sc.obstacles):
        for f in ("x0", "y0", "x1", "y1", "height"):
            v = getattr(o, f)
            if not -EXTENT_M <= v <= EXTENT_M:
                raise ConfigError(f"obstacles[{i}].{f}", f"must be within +-{EXTENT_M:g} m, got {v!r}")


def _check_map(world: WorldSection, obstacles: tuple[Obstacle, ...]) -> None:
    """Reads the map and grid, and places the obstacles, as the world will: a bad one is refused
    now, naming its field, not by the world once the run has started."""
    try:
        lab = load_lab(world.map)
        if world.grid is not None:
            load_grid(world.grid, lab)
    except MapError as e:
        field = "world.grid" if world.grid is not None and str(world.grid) in str(e) else "world.map"
        raise ConfigError(field, str(e)) from None
    placed = Obstacles(lab)
    for i, o in enumerate(obstacles):
        if why := placed.apply("add_obstacle", o):
            raise ConfigError(f"obstacles[{i}]", why)


def parse_scenario(text: str, base: Path, name: str = "scenario", sets: Sequence[tuple[str, Any]] = ()) -> Scenario:
    """Reads a scenario from TOML text.

    Args:
        text: The TOML.
        base: Folder that relative paths are taken from.
        name: The scenario's name (its file name), unless the file names it.
        sets: Fields changed from the command line, ``(path, value)`` (``--set``,
            :mod:`iw_zenoh.scenario.fields`), before the scenario is checked.

    Raises:
        ConfigError: Naming the field and the reason.
    """
    doc = _toml(text, name)
    if sets:
        _numbers(apply_sets(doc, sets))
    old_names(doc, text)
    try:
        sc = msgspec.convert(doc, ScenarioFile, dec_hook=_dec_path)
    except msgspec.ValidationError as e:
        raise _refusal(e, doc, name) from None
    _check_ranges(sc)
    world = msgspec.structs.replace(
        sc.world, map=_beside(base, sc.world.map), grid=_beside(base, sc.world.grid) if sc.world.grid else None
    )
    _exists(world.map, "world.map")
    _exists(world.grid, "world.grid")
    _check_map(world, sc.obstacles)
    bridge = sc.bridge
    if bridge is not None and bridge.params is not None:
        bridge = msgspec.structs.replace(bridge, params=_beside(base, bridge.params))
        _exists(bridge.params, "bridge.params")
    for i, d in enumerate(sc.criteria.doors):
        if d.one_chair_within_m is not None and (d.x_m is None or d.y_m is None):
            raise ConfigError(f"criteria.doors[{i}].one_chair_within_m", "needs the doorway's middle: x_m and y_m")
    if sc.world.args:
        raise ConfigError(f"{at_line(text, 'world', 'args')}world.args", args_table(sc.world.args))
    chair = sc.chair
    if chair is not None and isinstance(chair.start, str):
        raise ConfigError("chair.start", start_table(chair.start))
    if chair is not None and isinstance(chair.room, str):
        raise ConfigError(f"{at_line(text, 'chair', 'room')}chair.room", room_table(chair.room))
    if chair is not None and world.mode != Mode.REALTIME:
        raise ConfigError("chair.hardware", "a chair on a serial link moves in real time: world.mode must be realtime")
    if chair is not None and chair.spec is not None:
        spec_file = _beside(base, chair.spec)
        _exists(spec_file, "chair.spec")
        check_spec(load_spec_file(spec_file), where=f"chair.spec: {spec_file}: {SPEC_TABLE}")
        chair = msgspec.structs.replace(chair, spec=spec_file)
    agents = tuple(_with_spec(a, i, base, text) for i, a in enumerate(sc.agents))
    fields = {**msgspec.structs.asdict(sc), "world": world, "bridge": bridge, "chair": chair, "agents": agents}
    return Scenario(**{**fields, "name": sc.name or name}, base=base)


def _beside(base: Path, path: Path | str) -> Path:
    """``path`` as the scenario in ``base`` names it, ``..`` folded (``maps/scenarios/../liacc.xml``
    is ``maps/liacc.xml`` in every message and error)."""
    return Path(os.path.normpath(base / path))


def _with_spec(agent: AgentEntry, i: int, base: Path, text: str) -> AgentEntry:
    """An agent whose spec is read (a file's table) and checked as a registration would be; a
    field of its own table under its name from before it carried its unit is refused at its line."""
    if agent.spec is None:
        return agent
    where = f"agents[{i}].spec"
    table = agent.spec
    renamed = renamed_field(table) if isinstance(table, dict) else None
    if renamed is not None:
        line = line_of(text, renamed[1])
        at = f"line {line}: " if line else ""
        raise ConfigError(
            f"{at}{where}{renamed[0]}",
            f"{renamed[1]!r} is now {renamed[2]!r}: spec fields carry their units (docs/spec.md)",
        )
    if isinstance(table, str):
        path = _beside(base, table)
        _exists(path, where)
        table = load_spec_file(path)
        where = f"{where}: {path}: {SPEC_TABLE}"
    check_spec(table, where=where)
    return msgspec.structs.replace(agent, spec=table)


def load_scenario(path: str | Path, sets: Sequence[tuple[str, Any]] = ()) -> Scenario:
    """Reads a scenario file (``sets``: fields changed, as :func:`parse_scenario` takes them).

    Raises:
        ConfigError: Naming the file, the field and the reason, when it cannot be read or is refused.
    """
    p = Path(path)
    try:
        text = p.read_bytes().decode("utf-8")
    except OSError as e:
        raise ConfigError(str(p), f"cannot read it: {e.strerror}") from None
    except UnicodeDecodeError as e:
        raise ConfigError(str(p), f"not a text file (UTF-8 TOML): {e.reason} at byte {e.start}") from None
    try:
        return parse_scenario(text, p.parent, p.stem, sets)
    except ConfigError as e:
        raise ConfigError(f"{p}: {e.field}", e.reason) from None
