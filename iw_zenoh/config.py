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
import re
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

import msgspec

from iw_zenoh.core.modes import Mode, Profile
from iw_zenoh.errors import ConfigError
from iw_zenoh.messages import Obstacle
from iw_zenoh.specfile import SPEC_TABLE, check_spec, load_spec_file

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
    "WorldSection",
    "load_scenario",
    "parse_scenario",
]

ObstacleEntry = Obstacle  # a scenario's obstacle is the very message the world is sent
Arg = str | int | float  # an argument as TOML writes it; handed on as its text


class WorldSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[world]``: the map and how the world runs."""

    map: Path
    grid: Path | None = None
    mode: Mode = Mode.REALTIME
    profile: Profile = Profile.NATIVE
    period_ms: Annotated[float, msgspec.Meta(gt=0)] = 100.0
    seed: Annotated[int, msgspec.Meta(ge=0)] = 0  # numpy takes no negative seed
    duration_s: Annotated[float, msgspec.Meta(gt=0)] = 60.0
    args: tuple[Arg, ...] = ()

    @property
    def argv(self) -> list[str]:
        """``args`` as a command line takes them."""
        return [str(a) for a in self.args]


class RolesSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[roles]``: which roles run beside the world, and how many."""

    sensors_shards: Annotated[int, msgspec.Meta(ge=1)] = 1
    radio: bool = True


class AgentEntry(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[[agents]]``: one agent process: a program of ``iw_zenoh.agents``, or the user's own file
    (``./my_agent.py[:Name]``, relative to the scenario), and its arguments."""

    program: str
    args: tuple[Arg, ...] = ()
    robots: Annotated[int, msgspec.Meta(ge=0)] = 1
    name: str = ""
    # its robots' spec as data (docs/spec.md): a table of the registration's fields, or a spec
    # file's path; read and checked when the scenario is, then handed to the agent as a table
    spec: dict[str, Any] | str | None = None

    @property
    def argv(self) -> list[str]:
        """``args`` as a command line takes them."""
        return [str(a) for a in self.args]


class Reach(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[[criteria.reach]]``: robot ``robot`` must come within ``within`` metres of (x, y)."""

    robot: int
    x: float
    y: float
    within: Annotated[float, msgspec.Meta(gt=0)] = 0.5


class DoorCriterion(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[[criteria.doors]]``: what door ``robot`` must do (``iw_zenoh/sim/doorwatch.py`` judges it).

    Its pose when first seen is its closed pose. It opened once it moved ``OPEN_M`` or turned
    ``OPEN_DEG`` from there; it is closed again when back within ``SHUT_M`` and ``SHUT_DEG`` (its
    heading taken modulo ``symmetry_deg``: a four-wing revolving door looks shut every 90 degrees).
    """

    robot: int
    opened: bool = True
    closed_again: bool = True
    x: float | None = None
    y: float | None = None
    one_chair_within: Annotated[float, msgspec.Meta(gt=0)] | None = None
    symmetry_deg: Annotated[float, msgspec.Meta(gt=0, le=360)] = 360.0


class Criteria(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[criteria]``: what makes a run a success."""

    max_collisions: Annotated[int, msgspec.Meta(ge=0)] | None = None
    reach: tuple[Reach, ...] = ()
    doors: tuple[DoorCriterion, ...] = ()
    stop_when_reached: bool = True


class BridgeSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[bridge]``: a legacy XML/UDP bridge (Ciber-Rato) beside the world."""

    port: Annotated[int, msgspec.Meta(ge=1, le=65535)] = 6000
    params: Path | None = None
    scoring: Literal[0, 1, 2, 3] = 0


class ChairSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[chair]``: a real chair on a serial link (``docs/serial.md``): ``iwz bridge serial``, and
    without a ``port`` the chair emulator on a pseudo-terminal. The world must run in real time."""

    hardware: Literal["serial"] = "serial"
    port: str = ""  # the chair's device or pyserial URL; "": `iwz chair emulate --pty` stands in
    robot: Annotated[int, msgspec.Meta(ge=1)] = 1  # the robot id the bridge registers
    name: str = "chair"
    start: Annotated[str, msgspec.Meta(pattern=r"^[^,]+,[^,]+,[^,]+$")] = "1,1,0"  # x,y,dir_deg
    room: str = ""  # emulator: real obstacles not in the map, x0,y0,x1,y1;...
    seed: int = 0  # emulator: noise seed
    baud: Annotated[int, msgspec.Meta(gt=0)] = 115200
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
    name: str = ""
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
    """msgspec's error as a ConfigError: the field's dotted path (``agents[0].robots``) and the reason."""
    m = _AT.match(str(error))
    assert m is not None  # the pattern matches any text
    reason, path = m["reason"], (m["path"] or "").lstrip(".")
    named = _NAMED.match(reason)
    if named:
        path = f"{path}.{named['field']}" if path else named["field"]
        reason = "is required" if "missing" in reason else "unknown field"
    elif "got" not in reason and "value" not in reason:
        with contextlib.suppress(KeyError, IndexError, TypeError, ValueError):  # else the reason stands alone
            reason = f"{reason}, got {_value_at(doc, path)!r}"
    if not re.search(r"[.\[]", path):  # a top-level field is named after the scenario
        path = f"{name}.{path}" if path else name
    return ConfigError(path, reason)


def _exists(path: Path | None, where: str) -> None:
    if path is not None and not path.is_file():
        raise ConfigError(where, f"{path} does not exist")


def parse_scenario(text: str, base: Path, name: str = "scenario") -> Scenario:
    """Reads a scenario from TOML text.

    Args:
        text: The TOML.
        base: Folder that relative paths are taken from.
        name: The scenario's name (its file name), unless the file names it.

    Raises:
        ConfigError: Naming the field and the reason.
    """
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(name, f"not valid TOML: {e}") from None
    try:
        sc = msgspec.convert(doc, ScenarioFile, dec_hook=_dec_path)
    except msgspec.ValidationError as e:
        raise _refusal(e, doc, name) from None
    world = msgspec.structs.replace(
        sc.world, map=base / sc.world.map, grid=base / sc.world.grid if sc.world.grid else None
    )
    _exists(world.map, "world.map")
    _exists(world.grid, "world.grid")
    bridge = sc.bridge
    if bridge is not None and bridge.params is not None:
        bridge = msgspec.structs.replace(bridge, params=base / bridge.params)
        _exists(bridge.params, "bridge.params")
    for i, d in enumerate(sc.criteria.doors):
        if d.one_chair_within is not None and (d.x is None or d.y is None):
            raise ConfigError(f"criteria.doors[{i}].one_chair_within", "needs the doorway's middle: give x and y too")
    chair = sc.chair
    if chair is not None and world.mode != Mode.REALTIME:
        raise ConfigError("chair.hardware", "a chair on a serial link moves in real time: world.mode must be realtime")
    if chair is not None and chair.spec is not None:
        spec_file = base / chair.spec
        _exists(spec_file, "chair.spec")
        check_spec(load_spec_file(spec_file), where=f"chair.spec: {spec_file}: {SPEC_TABLE}")
        chair = msgspec.structs.replace(chair, spec=spec_file)
    agents = tuple(_with_spec(a, i, base) for i, a in enumerate(sc.agents))
    fields = {**msgspec.structs.asdict(sc), "world": world, "bridge": bridge, "chair": chair, "agents": agents}
    return Scenario(**{**fields, "name": sc.name or name}, base=base)


def _with_spec(agent: AgentEntry, i: int, base: Path) -> AgentEntry:
    """An agent whose spec is read (a file's table) and checked as a registration would be."""
    if agent.spec is None:
        return agent
    where = f"agents[{i}].spec"
    table = agent.spec
    if isinstance(table, str):
        path = base / table
        _exists(path, where)
        table = load_spec_file(path)
        where = f"{where}: {path}: {SPEC_TABLE}"
    check_spec(table, where=where)
    return msgspec.structs.replace(agent, spec=table)


def load_scenario(path: str | Path) -> Scenario:
    """Reads a scenario file.

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
        return parse_scenario(text, p.parent, p.stem)
    except ConfigError as e:
        raise ConfigError(f"{p}: {e.field}", e.reason) from None
