"""Scenario files (TOML): what ``iwz run`` starts and how it judges the run.

A scenario names the map, grid, mode, period, seed and duration; the robots' agent programs with
their arguments; obstacles; and success criteria. A bad scenario is refused with
:class:`~iw_zenoh.errors.ConfigError` naming the field and the reason. Paths are relative to the
scenario file. See ``docs/scenarios.md`` for every field.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from iw_zenoh.core.modes import Mode, Profile
from iw_zenoh.errors import ConfigError

__all__ = ["AgentEntry", "Criteria", "ObstacleEntry", "Reach", "Scenario", "load_scenario", "parse_scenario"]


@dataclass(frozen=True)
class AgentEntry:
    """One agent process: a program of ``iw_zenoh.agents`` and its arguments."""

    program: str
    args: tuple[str, ...] = ()
    robots: int = 1
    name: str = ""


@dataclass(frozen=True)
class ObstacleEntry:
    """A rectangular obstacle placed before the first tick."""

    name: str
    x0: float
    y0: float
    x1: float
    y1: float
    height: float = 1.0


@dataclass(frozen=True)
class Reach:
    """Robot ``robot`` must come within ``within`` metres of (x, y)."""

    robot: int
    x: float
    y: float
    within: float = 0.5


@dataclass(frozen=True)
class Criteria:
    """What makes a run a success."""

    max_collisions: int | None = None
    reach: tuple[Reach, ...] = ()
    stop_when_reached: bool = True


@dataclass(frozen=True)
class Scenario:
    """A whole run."""

    name: str
    map: Path
    grid: Path | None = None
    mode: Mode = Mode.REALTIME
    profile: Profile = Profile.NATIVE
    period_ms: float = 100.0
    seed: int = 0
    duration_s: float = 60.0
    sensors_shards: int = 1
    radio: bool = True
    agents: tuple[AgentEntry, ...] = ()
    obstacles: tuple[ObstacleEntry, ...] = ()
    criteria: Criteria = field(default_factory=Criteria)
    world_args: tuple[str, ...] = ()
    bridge_port: int | None = None  # a legacy XML/UDP bridge on this UDP port
    bridge_params: Path | None = None  # the Ciber-Rato parameters file it tells clients
    bridge_scoring: int = 0  # the legacy --scoring mode (0 competitive, 1 control, 2 mapping, 3 planning)
    base: Path = Path(".")  # the scenario's folder: agents run there, so their file arguments are relative to it

    @property
    def robots(self) -> int:
        """Robots the agents register in all."""
        return sum(a.robots for a in self.agents)


def _take(
    d: dict[str, Any],
    key: str,
    kind: type | tuple[type, ...],
    where: str,
    default: Any = None,
    *,
    required: bool = False,
) -> Any:
    if key not in d:
        if required:
            raise ConfigError(f"{where}.{key}", "is required")
        return default
    v = d[key]
    if kind is float and isinstance(v, int) and not isinstance(v, bool):
        v = float(v)
    if not isinstance(v, kind) or (isinstance(v, bool) and kind in (int, float)):
        name = kind.__name__ if isinstance(kind, type) else " or ".join(k.__name__ for k in kind)
        raise ConfigError(f"{where}.{key}", f"must be a {name}, got {v!r}")
    return v


def _no_extra(d: dict[str, Any], allowed: set[str], where: str) -> None:
    extra = sorted(set(d) - allowed)
    if extra:
        raise ConfigError(f"{where}.{extra[0]}", f"unknown field; expected one of {', '.join(sorted(allowed))}")


def parse_scenario(text: str, base: Path, name: str = "scenario") -> Scenario:
    """Reads a scenario from TOML text.

    Args:
        text: The TOML.
        base: Folder that relative paths are taken from.
        name: The scenario's name (its file name).

    Raises:
        ConfigError: Naming the field and the reason.
    """
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(name, f"not valid TOML: {e}") from None
    _no_extra(doc, {"world", "roles", "agents", "obstacles", "criteria", "name", "bridge"}, name)
    w = _take(doc, "world", dict, name, required=True)
    _no_extra(w, {"map", "grid", "mode", "profile", "period_ms", "seed", "duration_s", "args"}, "world")
    map_path = base / _take(w, "map", str, "world", required=True)
    if not map_path.is_file():
        raise ConfigError("world.map", f"{map_path} does not exist")
    grid = _take(w, "grid", str, "world")
    grid_path = base / grid if grid else None
    if grid_path is not None and not grid_path.is_file():
        raise ConfigError("world.grid", f"{grid_path} does not exist")
    mode = _take(w, "mode", str, "world", Mode.REALTIME)
    if mode not in tuple(Mode):
        raise ConfigError("world.mode", f"must be realtime or lockstep, got {mode!r}")
    profile = _take(w, "profile", str, "world", Profile.NATIVE)
    if profile not in tuple(Profile):
        raise ConfigError("world.profile", f"must be native or ciberrato, got {profile!r}")
    period = _take(w, "period_ms", float, "world", 100.0)
    if period <= 0:
        raise ConfigError("world.period_ms", f"must be > 0, got {period!r}")
    duration = _take(w, "duration_s", float, "world", 60.0)
    if duration <= 0:
        raise ConfigError("world.duration_s", f"must be > 0, got {duration!r}")
    world_args = tuple(str(a) for a in _take(w, "args", list, "world", []))

    roles = _take(doc, "roles", dict, name, {})
    _no_extra(roles, {"sensors_shards", "radio"}, "roles")
    shards = _take(roles, "sensors_shards", int, "roles", 1)
    if shards < 1:
        raise ConfigError("roles.sensors_shards", f"must be >= 1, got {shards}")

    agents: list[AgentEntry] = []
    for i, a in enumerate(_take(doc, "agents", list, name, [])):
        where = f"agents[{i}]"
        if not isinstance(a, dict):
            raise ConfigError(where, "must be a table")
        _no_extra(a, {"program", "args", "robots", "name"}, where)
        args = _take(a, "args", list, where, [])
        if not all(isinstance(x, str | int | float) for x in args):
            raise ConfigError(f"{where}.args", "must be a list of strings")
        robots = _take(a, "robots", int, where, 1)
        if robots < 0:
            raise ConfigError(f"{where}.robots", f"must be >= 0, got {robots}")
        agents.append(
            AgentEntry(
                _take(a, "program", str, where, required=True),
                tuple(str(x) for x in args),
                robots,
                _take(a, "name", str, where, ""),
            )
        )

    obstacles: list[ObstacleEntry] = []
    for i, o in enumerate(_take(doc, "obstacles", list, name, [])):
        where = f"obstacles[{i}]"
        if not isinstance(o, dict):
            raise ConfigError(where, "must be a table")
        _no_extra(o, {"name", "x0", "y0", "x1", "y1", "height"}, where)
        x0, y0, x1, y1 = (_take(o, k, float, where, required=True) for k in ("x0", "y0", "x1", "y1"))
        obstacles.append(
            ObstacleEntry(
                _take(o, "name", str, where, required=True), x0, y0, x1, y1, _take(o, "height", float, where, 1.0)
            )
        )

    c = _take(doc, "criteria", dict, name, {})
    _no_extra(c, {"max_collisions", "reach", "stop_when_reached"}, "criteria")
    reach: list[Reach] = []
    for i, r in enumerate(_take(c, "reach", list, "criteria", [])):
        where = f"criteria.reach[{i}]"
        if not isinstance(r, dict):
            raise ConfigError(where, "must be a table")
        _no_extra(r, {"robot", "x", "y", "within"}, where)
        within = _take(r, "within", float, where, 0.5)
        if within <= 0:
            raise ConfigError(f"{where}.within", f"must be > 0, got {within}")
        reach.append(
            Reach(
                _take(r, "robot", int, where, required=True),
                _take(r, "x", float, where, required=True),
                _take(r, "y", float, where, required=True),
                within,
            )
        )
    maxc = _take(c, "max_collisions", int, "criteria")
    if maxc is not None and maxc < 0:
        raise ConfigError("criteria.max_collisions", f"must be >= 0, got {maxc}")
    criteria = Criteria(maxc, tuple(reach), _take(c, "stop_when_reached", bool, "criteria", True))
    b = _take(doc, "bridge", dict, name, None)
    bridge_port: int | None = None
    bridge_params: Path | None = None
    bridge_scoring = 0
    if b is not None:
        _no_extra(b, {"port", "params", "scoring"}, "bridge")
        bridge_scoring = _take(b, "scoring", int, "bridge", 0)
        if bridge_scoring not in (0, 1, 2, 3):
            raise ConfigError(
                "bridge.scoring",
                f"must be 0 (competitive), 1 (control), 2 (mapping) or 3 (planning), got {bridge_scoring}",
            )
        bridge_port = _take(b, "port", int, "bridge", 6000)
        if not 0 < bridge_port < 65536:
            raise ConfigError("bridge.port", f"must be a UDP port (1..65535), got {bridge_port}")
        raw = _take(b, "params", str, "bridge")
        if raw is not None:
            bridge_params = base / raw
            if not bridge_params.is_file():
                raise ConfigError("bridge.params", f"{bridge_params} does not exist")
    return Scenario(
        name=_take(doc, "name", str, name, name),
        map=map_path,
        grid=grid_path,
        mode=Mode(mode),
        profile=Profile(profile),
        period_ms=period,
        seed=_take(w, "seed", int, "world", 0),
        duration_s=duration,
        sensors_shards=shards,
        radio=_take(roles, "radio", bool, "roles", True),
        agents=tuple(agents),
        obstacles=tuple(obstacles),
        criteria=criteria,
        world_args=world_args,
        bridge_port=bridge_port,
        bridge_params=bridge_params,
        bridge_scoring=bridge_scoring,
        base=base,
    )


def load_scenario(path: str | Path) -> Scenario:
    """Reads a scenario file.

    Raises:
        ConfigError: When it cannot be read or is refused.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise ConfigError(str(p), f"cannot read it: {e.strerror}") from None
    try:
        return parse_scenario(text, p.parent, p.stem)
    except ConfigError as e:
        raise ConfigError(f"{p}: {e.field}", e.reason) from None
