"""docs/layout.md places every module of the package, the agents and the bridges."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TREES = ("iw_zenoh", "agents", "bridges")


def _sections(text: str) -> list[tuple[str, set[str]]]:
    """Each heading's folder (the last `path/` it names) and the module names in its table."""
    out: list[tuple[str, set[str]]] = []
    for block in re.split(r"^#+ ", text, flags=re.M)[1:]:
        heading, _, body = block.partition("\n")
        folders = re.findall(r"`([\w/]+/)`", heading)
        names = set(re.findall(r"^\| `([\w]+\.py)` \|", body, flags=re.M))
        if folders and names:
            out.append((folders[-1], names))
    return out


def test_every_module_has_a_line_in_docs_layout() -> None:
    placed = {folder + n for folder, names in _sections((ROOT / "docs" / "layout.md").read_text()) for n in names}
    modules = {
        p.relative_to(ROOT).as_posix()
        for tree in TREES
        for p in (ROOT / tree).rglob("*.py")
        if p.name != "__init__.py" and "__pycache__" not in p.parts
    }
    missing = sorted(modules - placed)
    assert not missing, f"docs/layout.md does not place: {missing}"
    gone = sorted(placed - modules)
    assert not gone, f"docs/layout.md names modules that do not exist: {gone}"
