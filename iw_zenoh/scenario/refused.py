"""Forms scenarios once wrote, refused with what to write instead: ``[world] args`` (``iwz world``
flags as strings, now typed fields of ``[world]``), ``[chair] start = "x,y,dir"`` (now a table),
``[chair] room = "x0,y0,x1,y1;..."`` (now an array of tables), and the criteria's lengths named
without their unit (``x``, ``within``: now ``x_m``, ``within_m``)."""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from typing import Any

from iw_zenoh.errors import ConfigError
from iw_zenoh.scenario.specfile import line_of

__all__ = ["RENAMED", "args_table", "at_line", "line_in", "old_names", "room_table", "start_table"]

# the fields of a scenario's tables renamed to carry their unit, by table: old name -> new name
RENAMED: dict[str, dict[str, str]] = {
    "criteria.reach": {"x": "x_m", "y": "y_m", "within": "within_m"},
    "criteria.doors": {"x": "x_m", "y": "y_m", "one_chair_within": "one_chair_within_m"},
}

Arg = str | int | float  # an argument as TOML writes it


def start_table(text: str) -> str:
    """Why ``start = "x,y,dir_deg"`` (a string, as scenarios once wrote it) is refused, and what to write."""
    parts = [p.strip() for p in text.split(",")]
    form = "{ x_m = 1.5, y_m = 3.0, dir_deg = 0.0 }"
    if len(parts) == 3 and all(re.fullmatch(r"[-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?", p) for p in parts):
        form = f"{{ x_m = {parts[0]}, y_m = {parts[1]}, dir_deg = {parts[2]} }}"
    return f"a table now, not a string {text!r}: write start = {form} (docs/scenarios.md)"


def room_table(text: str) -> str:
    """Why ``room = "x0,y0,x1,y1;..."`` (a string, as scenarios once wrote it) is refused, and what to write."""
    number = r"[-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?"
    boxes = [[p.strip() for p in box.split(",")] for box in text.split(";") if box.strip()]
    form = "[{ x0_m = 8.2, y0_m = 3.4, x1_m = 8.8, y1_m = 5.0 }]"
    if all(len(b) == 4 and all(re.fullmatch(number, p) for p in b) for b in boxes):
        form = "[" + ", ".join("{{ x0_m = {}, y0_m = {}, x1_m = {}, y1_m = {} }}".format(*b) for b in boxes) + "]"
    return f"an array of tables now, not a string {text!r}: write room = {form} (docs/scenarios.md)"


# the flags of ``iwz world`` a scenario once wrote in ``[world] args``, by the field that says each now
_FLAG_FIELDS = {
    "--action-timeout-ms": "action_timeout_ms",
    "--grace-ms": "grace_ms",
    "--lockstep-timeout-ms": "lockstep_timeout_ms",
    "--motors-noise": "motors_noise_pct",
    "--silence": "silence",
    "--expect": "expect",
    "--seed": "seed",
    "--period-ms": "period_ms",
    "--profile": "profile",
    "--duration": "duration_s",
}


def line_in(text: str, table: str, key: str) -> int:
    """The line of TOML ``text`` that sets ``key`` in ``[table]`` (1-based), or 0."""
    lines = text.splitlines()
    header = re.compile(rf"^\s*\[\s*{re.escape(table)}\s*\]")
    start = next((n for n, line in enumerate(lines) if header.match(line)), None)
    if start is None:
        return 0
    end = next((n for n in range(start + 1, len(lines)) if re.match(r"^\s*\[", lines[n])), len(lines))
    found = line_of("\n".join(lines[start + 1 : end]), key)
    return start + 1 + found if found else 0


def at_line(text: str, table: str, key: str) -> str:
    """``line N: `` where TOML ``text`` sets ``key`` in ``[table]`` ("" if it does not say)."""
    line = line_in(text, table, key)
    return f"line {line}: " if line else ""


def args_table(args: Sequence[Arg]) -> str:
    """Why ``[world] args = [...]`` (``iwz world`` flags, as scenarios once wrote them) is refused,
    and the fields of ``[world]`` to write instead."""
    fields: list[str] = []
    rest = list(args)
    while rest:
        flag = str(rest.pop(0))
        if flag == "--paused":
            fields.append("start_paused = true")
        elif flag == "--lockstep":
            fields.append('mode = "lockstep"')
        elif flag in _FLAG_FIELDS and rest:
            value = rest.pop(0)
            number = isinstance(value, int | float) or re.fullmatch(r"[-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?", str(value))
            fields.append(f"{_FLAG_FIELDS[flag]} = {value if number else json.dumps(str(value))}")
        else:
            fields = []
            break
    form = (
        "; ".join(fields)
        if fields
        else "each option as its field (--lockstep-timeout-ms 60000: lockstep_timeout_ms = 60000)"
    )
    return f"is gone: [world] takes the world's options as typed fields: write {form} (docs/scenarios.md)"


def _item_line(text: str, array: str, index: int, key: str) -> int:
    """The line of TOML ``text`` that sets ``key`` in the ``index``-th ``[[array]]`` (1-based), or 0."""
    lines = text.splitlines()
    header = re.compile(rf"^\s*\[\[\s*{re.escape(array)}\s*\]\]")
    starts = [n for n, line in enumerate(lines) if header.match(line)]
    if index >= len(starts):
        return 0  # written inline (reach = [{ ... }]) or set from the command line
    start = starts[index]
    end = next((n for n in range(start + 1, len(lines)) if re.match(r"^\s*\[", lines[n])), len(lines))
    found = line_of("\n".join(lines[start + 1 : end]), key)
    return start + 1 + found if found else 0


def old_names(doc: dict[str, Any], text: str) -> None:
    """Refuses a field of a scenario's table under its name from before it carried its unit
    (:data:`RENAMED`), at its line, naming the field to write.

    Raises:
        ConfigError: ``line N: criteria.reach[0].x``: ``'x' is now 'x_m'``.
    """
    for path, names in RENAMED.items():
        table, _, array = path.partition(".")
        items = doc.get(table, {}).get(array, []) if isinstance(doc.get(table), dict) else []
        for i, item in enumerate(items if isinstance(items, list) else []):
            for old in (k for k in names if isinstance(item, dict) and k in item):
                line = _item_line(text, path, i, old)
                at = f"line {line}: " if line else ""
                raise ConfigError(
                    f"{at}{path}[{i}].{old}",
                    f"{old!r} is now {names[old]!r}: lengths carry their unit (docs/scenarios.md)",
                )
