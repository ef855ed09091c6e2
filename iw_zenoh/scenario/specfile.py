"""A robot's spec as data: a table of the registration's own fields laid over a chair.

The table's keys are the fields of :class:`~iw_zenoh.messages.RobotSpecMsg`, the registration the
world is sent, named as :class:`~iw_zenoh.core.spec.RobotSpec`'s (``width_m``, ``com``,
``max_speed_mps``, ``ir_sensors = [{id, x_m, y_m, angle_deg, cone_deg, range_m}, ...]``,
``[noise.gps_m] std = 0.1``...), so every field a registration has (and any a new sensor type
adds to it) can be given, and nothing else. A name from before they carried their units
(``width``, ``max_speed``, ``dir``...) is refused with the name to write instead. A given field replaces the chair's,
a table (``noise``) is merged field by field, a list (``ir_sensors``) replaces the chair's whole.
``noise = false`` (or ``true``) switches every noise of the chair off (or on) at once.

The result is checked as a registration is: msgspec decodes it into ``RobotSpecMsg`` (types,
unknown fields) and :func:`~iw_zenoh.convert.spec_from_msg` checks the ranges, so a table is
refused exactly where a registration would be, with :class:`~iw_zenoh.errors.ConfigError` naming
the field's path (``agents[0].spec.ir_sensors[2].range_m: must be > 0, got 0.0``).

A spec file (``chair.toml``, what ``iwz agent --spec`` and ``iwz bridge serial --spec`` read) is
TOML with the table as ``[chair]``. See ``docs/spec.md``.
"""

from __future__ import annotations

import copy
import re
import tomllib
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import msgspec

from iw_zenoh.convert import spec_from_msg, spec_to_msg
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.errors import ConfigError, SpecError
from iw_zenoh.messages import RobotSpecMsg, SensorNoiseMsg
from iw_zenoh.messages.world import RENAMED_SENSOR_FIELDS, RENAMED_SPEC_FIELDS

__all__ = ["SPEC_TABLE", "apply_spec", "check_spec", "line_of", "load_spec_file", "renamed_field", "spec_with_args"]

SPEC_TABLE = "chair"  # the table of a spec file that holds the spec
NOISE_SWITCH = "noise"  # `noise = false`: every noise off
_AT = re.compile(r"^(?P<reason>.*?)(?: - at `\$(?P<path>[^`]*)`)?$", re.DOTALL)
_NAMED = re.compile(r"Object (?:missing required|contains unknown) field `(?P<field>[^`]+)`")

Table = Mapping[str, Any]
Path_ = tuple[str | int, ...]


def load_spec_file(path: str | Path) -> dict[str, Any]:
    """The spec table of a spec file (its ``[chair]`` table), not yet checked (see :func:`apply_spec`).

    Raises:
        ConfigError: The file cannot be read, is not TOML, or has no ``[chair]`` table or other tables.
    """
    p = Path(path)
    try:
        doc = tomllib.loads(p.read_bytes().decode("utf-8"))
    except OSError as e:
        raise ConfigError(str(p), f"cannot read it: {e.strerror}") from None
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise ConfigError(str(p), f"not a TOML file: {e}") from None
    other = sorted(set(doc) - {SPEC_TABLE})
    if other:
        raise ConfigError(
            f"{p}: {other[0]}", f"not under [{SPEC_TABLE}]: a spec file holds its fields in [{SPEC_TABLE}]"
        )
    table = doc.get(SPEC_TABLE)
    if not isinstance(table, dict):
        raise ConfigError(str(p), f"no [{SPEC_TABLE}] table: write the fields under [{SPEC_TABLE}] (docs/spec.md)")
    old = renamed_field(table)
    if old is not None:
        path, name, new = old
        line = line_of(p.read_text(encoding="utf-8", errors="replace"), name)
        raise ConfigError(f"{p}{f', line {line}' if line else ''}: {SPEC_TABLE}{path}", _rename_reason(name, new))
    return table


def renamed_field(table: Table) -> tuple[str, str, str] | None:
    """The first field of a spec table written with its name from before it carried its unit.

    Args:
        table: A spec table (see the module's docstring).

    Returns:
        ``(path, old, new)``, e.g. ``(".ir_sensors[0].x", "x", "x_m")``; None when every name is current.
    """
    for key in table:
        if key in RENAMED_SPEC_FIELDS:
            return f".{key}", key, RENAMED_SPEC_FIELDS[key]
    for kind in ("ir_sensors", "lasers"):
        items = table.get(kind)
        for i, item in enumerate(items if isinstance(items, list) else []):
            for key in item if isinstance(item, dict) else ():
                if key in RENAMED_SENSOR_FIELDS:
                    return f".{kind}[{i}].{key}", key, RENAMED_SENSOR_FIELDS[key]
    return None


def _rename_reason(old: str, new: str) -> str:
    return f"{old!r} is now {new!r}: spec fields carry their units, as in Python (docs/spec.md)"


def line_of(text: str, key: str) -> int:
    """The first line of TOML ``text`` that sets ``key`` (``key = ...``, also in an inline table), or 0."""
    pattern = re.compile(rf"(?:^|[{{,\s]){re.escape(key)}\s*=")
    for n, line in enumerate(text.splitlines(), start=1):
        if pattern.search(line.split("#", 1)[0]):
            return n
    return 0


def apply_spec(base: RobotSpec, table: Table, *, where: str = SPEC_TABLE) -> RobotSpec:
    """``base`` with the fields ``table`` gives, checked as a registration.

    Args:
        base: The chair the table changes (an agent's own, or a default one).
        table: Fields of ``RobotSpecMsg`` (see the module's docstring).
        where: The table's place, the start of every refused field's path (``agents[0].spec``).

    Returns:
        The spec.

    Raises:
        ConfigError: Naming the field's path (``where.ir_sensors[2].range_m``) and the reason.
    """
    if not table:
        return base
    renamed = renamed_field(table)
    if renamed is not None:
        raise ConfigError(f"{where}{renamed[0]}", _rename_reason(renamed[1], renamed[2]))
    doc = msgspec.to_builtins(spec_to_msg(base))
    if not base.ir_sensors:  # the defaults of Table 4.5, placed from the body the table may change
        doc["ir_sensors"] = []
    noise = doc.setdefault("noise", {})
    for kind in SensorNoiseMsg.__struct_fields__:  # the wire leaves some out (laser_m without a scanner)
        own = getattr(base.noise, kind, None)
        if kind not in noise and own is not None:
            noise[kind] = {"mean": own.mean, "std": own.std, "enabled": own.enabled}
    changes = _expand_switch(table)
    try:
        return _checked(_merged(doc, changes))
    except msgspec.ValidationError as e:
        raise _refused(e, where) from None
    except SpecError:
        path, why = _culprit(doc, changes)
        raise ConfigError(f"{where}{path}", why) from None


def spec_with_args(spec: RobotSpec, args: object) -> RobotSpec:
    """``spec`` with the table ``iwz agent --spec`` read (``args.spec_table``; none: ``spec``).

    What an agent program calls on the chair it builds, so it drives the chair it registers.

    Raises:
        ConfigError: As :func:`apply_spec`.
    """
    table = getattr(args, "spec_table", None) or {}
    return apply_spec(spec, table, where=getattr(args, "spec_where", SPEC_TABLE))


def check_spec(table: Table, *, where: str = SPEC_TABLE) -> None:
    """Refuses a table that no chair could take (checked over the default chair).

    Raises:
        ConfigError: As :func:`apply_spec`.
    """
    apply_spec(RobotSpec("check"), table, where=where)


def _expand_switch(table: Table) -> dict[str, Any]:
    """``noise = true/false`` as every noise's ``enabled``."""
    out = dict(table)
    switch = out.get(NOISE_SWITCH)
    if isinstance(switch, bool):
        out[NOISE_SWITCH] = {kind: {"enabled": switch} for kind in SensorNoiseMsg.__struct_fields__}
    return out


def _merged(doc: dict[str, Any], changes: Table) -> dict[str, Any]:
    """``doc`` with ``changes``: tables merged field by field, anything else replaced."""
    out = copy.deepcopy(doc)
    for key, value in changes.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merged(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def _checked(doc: dict[str, Any]) -> RobotSpec:
    """The spec ``doc`` describes, checked as a registration (msgspec, then the ranges)."""
    return spec_from_msg(msgspec.convert(doc, RobotSpecMsg))


def _leaves(changes: Table, at: Path_ = ()) -> Iterator[tuple[Path_, Any]]:
    """Each change on its own, in order: a table's fields one by one, a list's items one by one."""
    for key, value in changes.items():
        if isinstance(value, dict):
            yield from _leaves(value, (*at, key))
        elif isinstance(value, list):
            yield (*at, key), []
            for i, item in enumerate(value):
                yield (*at, key, i), item
        else:
            yield (*at, key), value


def _set(doc: dict[str, Any], path: Path_, value: Any) -> None:
    target: Any = doc
    for step in path[:-1]:
        if isinstance(step, str) and not isinstance(target.get(step), dict | list):
            target[step] = {}  # a table the chair has none of (its None): built field by field
        target = target[step]
    last = path[-1]
    if isinstance(last, int):
        target.append(copy.deepcopy(value))
    elif isinstance(value, dict) and isinstance(target.get(last), dict):
        target[last] = _merged(target[last], value)
    else:
        target[last] = copy.deepcopy(value)


def _spelled(path: Path_) -> str:
    return "".join(f"[{s}]" if isinstance(s, int) else f".{s}" for s in path)


def _culprit(doc: dict[str, Any], changes: Table) -> tuple[str, str]:
    """The first change that makes a spec out of range, and why: the changes are made one at a
    time; a list item that is refused is narrowed to the one field whose default mends it."""
    built = copy.deepcopy(doc)
    for path, value in _leaves(changes):
        _set(built, path, value)
        try:
            _checked(built)
        except (SpecError, msgspec.ValidationError) as e:
            why = e.reason if isinstance(e, SpecError) else str(e)
            field = _narrowed(built, path, value)
            if field:
                return _spelled((*path, field)), why
            full = e.field if isinstance(e, SpecError) else ""
            return _spelled(path), why if _spelled(path).endswith(full.split(".")[-1]) else f"{full}: {why}"
    return "", "refused"  # not reached: the whole was refused, so one of its changes is


def _narrowed(built: dict[str, Any], path: Path_, value: Any) -> str:
    """The field of the list item just added (at ``path``) whose default mends the spec, or ""."""
    if not isinstance(path[-1], int) or not isinstance(value, dict):
        return ""
    items: Any = built
    for step in path[:-1]:
        items = items[step]
    for name in value:
        items[-1] = {k: v for k, v in value.items() if k != name}
        try:
            _checked(built)
        except (SpecError, msgspec.ValidationError):
            continue
        return str(name)
    return ""


def _refused(error: msgspec.ValidationError, where: str) -> ConfigError:
    """A msgspec refusal as a ConfigError naming the field's path."""
    m = _AT.match(str(error))
    assert m is not None  # the pattern matches any text
    reason, path = m["reason"], m["path"] or ""
    named = _NAMED.match(reason)
    if named:
        path = f"{path}.{named['field']}"
        reason = "is required" if "missing" in reason else "unknown field"
    return ConfigError(f"{where}{path}", reason)
