from __future__ import annotations

from pathlib import Path

import msgspec
import pytest

from iw_zenoh.scenario.tables import ScenarioFile

DOC = Path(__file__).resolve().parents[1] / "docs" / "scenarios.md"


def _tables(kind: type, seen: set[type]) -> None:
    """Every Struct a scenario file is made of, found from ``kind`` through its fields' types."""
    info = msgspec.inspect.type_info(kind)
    stack = [info]
    while stack:
        t = stack.pop()
        if isinstance(t, msgspec.inspect.StructType):
            if t.cls in seen:
                continue
            seen.add(t.cls)
            stack += [f.type for f in t.fields]
        for attr in ("item_type", "types"):
            inner = getattr(t, attr, None)
            if isinstance(inner, tuple):
                stack += list(inner)
            elif inner is not None:
                stack.append(inner)


def _fields() -> list[tuple[str, str]]:
    seen: set[type] = set()
    _tables(ScenarioFile, seen)
    return sorted((cls.__name__, f) for cls in seen for f in cls.__struct_fields__)


def test_the_scenario_tables_are_all_found() -> None:
    assert {c for c, _ in _fields()} >= {"ScenarioFile", "WorldSection", "AgentEntry", "Reach", "BridgeSection"}


@pytest.mark.parametrize(("table", "field"), _fields())
def test_every_scenario_field_is_documented(table: str, field: str) -> None:
    sections = DOC.read_text(encoding="utf-8").split("\n## ")
    mine = [s for s in sections if f"`{table}`" in s.splitlines()[0]]
    assert mine, f"docs/scenarios.md has no section headed by {table}"
    assert f"| `{field}` |" in mine[0], f"docs/scenarios.md has no row for {table}.{field} in its section"
