"""A scenario's fields changed from the command line: ``--set FIELD=VALUE`` (``iwz run`` and
``iwz study``).

``FIELD`` is the field's path in the scenario file, tables joined by ``.`` and array items by
``[i]``: ``world.seed``, ``world.duration_s``, ``agents[0].args``, ``agents[1].spec.max_speed_mps``,
``criteria.max_collisions``. ``VALUE`` is written as in the file (TOML): ``0.1``, ``true``,
``"text"``, ``[1, 2]``, ``{ std = 0.05 }``; a value that is not TOML is taken as text
(``--set world.map=../hall.xml``: paths are the file's, relative to the scenario's folder). A
table on the way that the file does not have is made. The scenario is then checked as a file
would be: an unknown field or a value out of range is refused naming the field.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Sequence
from typing import Any

from iw_zenoh.errors import ConfigError

__all__ = ["apply_sets", "parse_set"]

_PART = re.compile(r"([A-Za-z_][A-Za-z0-9_-]*)((?:\[\d+\])*)")
FORM = 'FIELD=VALUE, e.g. world.duration_s=30 or agents[0].args=["--id", "1"]'


def parse_set(text: str) -> tuple[str, Any]:
    """Reads ``FIELD=VALUE``: the field's path and the value (TOML, or else the text itself).

    Raises:
        ConfigError: No ``=``, or a path that is not ``name[.name|[i]]...``.
    """
    field, sep, raw = text.partition("=")
    field = field.strip()
    if not sep or not field:
        raise ConfigError("--set", f"takes {FORM}; got {text!r}")
    _steps(field)  # the path's form is checked now, not at the run
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw  # not TOML: the text (a path, a word)
    return field, value


def _steps(field: str) -> list[str | int]:
    """``a.b[0].c`` as ``["a", "b", 0, "c"]``."""
    steps: list[str | int] = []
    for part in field.split("."):
        m = _PART.fullmatch(part)
        if m is None:
            raise ConfigError("--set", f"{field!r} is not a field's path ({FORM})")
        steps.append(m[1])
        steps += [int(i) for i in re.findall(r"\[(\d+)\]", m[2])]
    return steps


def apply_sets(doc: dict[str, Any], sets: Sequence[tuple[str, Any]]) -> dict[str, Any]:
    """The scenario's decoded TOML with each ``(field, value)`` set, in order (``doc`` is changed).

    Raises:
        ConfigError: A path through something that is not a table or array, or an index past an
            array's end (naming the field).
    """
    for field, value in sets:
        steps = _steps(field)
        at: Any = doc
        for i, step in enumerate(steps):
            last = i == len(steps) - 1
            where = f"{field} (at {step!r})"
            if isinstance(step, int):
                if not isinstance(at, list) or step >= len(at):
                    size = f"an array of {len(at)}" if isinstance(at, list) else type(at).__name__
                    raise ConfigError(where, f"no item {step}: the file has {size} there")
                if last:
                    at[step] = value
                else:
                    at = at[step]
                continue
            if not isinstance(at, dict):
                raise ConfigError(where, f"is inside a {type(at).__name__}, not a table")
            if last:
                at[step] = value
            else:
                at = at.setdefault(step, [] if isinstance(steps[i + 1], int) else {})
    return doc
