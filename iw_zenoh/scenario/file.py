"""Scenario files (TOML): what ``iwz run`` starts and how it judges the run.

A scenario names the map, grid, mode, period, seed and duration; the robots' agent programs with
their arguments; obstacles; and success criteria. Its tables are the msgspec Structs of
:mod:`iw_zenoh.scenario.tables`: each field's name, type, range and default is declared once,
there, and msgspec decodes the TOML into them; this module reads, checks and refuses. A bad
scenario is refused with :class:`~iw_zenoh.errors.ConfigError` naming the file, the field
(``agents[0].robots``) and the reason. Paths are relative to the scenario file. See
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
from typing import Any

import msgspec

from iw_zenoh.core.modes import Mode
from iw_zenoh.errors import ConfigError, MapError
from iw_zenoh.maps import load_grid, load_lab
from iw_zenoh.messages import Obstacle
from iw_zenoh.scenario.fields import apply_sets
from iw_zenoh.scenario.refused import args_table, at_line, old_names, room_table, start_table
from iw_zenoh.scenario.specfile import SPEC_TABLE, check_spec, line_of, load_spec_file, renamed_field
from iw_zenoh.scenario.tables import (
    DEPTH_MAX,
    EXTENT_M,
    NAME,
    SEED_MAX,
    AgentEntry,
    Scenario,
    ScenarioFile,
    WorldSection,
)
from iw_zenoh.sim.obstacles import Obstacles

__all__ = ["load_scenario", "parse_scenario"]  # the tables themselves: iw_zenoh.scenario.tables


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
