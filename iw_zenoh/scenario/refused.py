"""Forms scenarios once wrote, refused with what to write instead: ``[world] args`` (``iwz world``
flags as strings, now typed fields of ``[world]``) and ``[chair] start = "x,y,dir"`` (now a table)."""

from __future__ import annotations

import json
import re
from collections.abc import Sequence

from iw_zenoh.scenario.specfile import line_of

__all__ = ["args_table", "line_in", "start_table"]

Arg = str | int | float  # an argument as TOML writes it


def start_table(text: str) -> str:
    """Why ``start = "x,y,dir_deg"`` (a string, as scenarios once wrote it) is refused, and what to write."""
    parts = [p.strip() for p in text.split(",")]
    form = "{ x_m = 1.5, y_m = 3.0, dir_deg = 0.0 }"
    if len(parts) == 3 and all(re.fullmatch(r"[-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?", p) for p in parts):
        form = f"{{ x_m = {parts[0]}, y_m = {parts[1]}, dir_deg = {parts[2]} }}"
    return f"a table now, not a string {text!r}: write start = {form} (docs/scenarios.md)"


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
