"""The layers hold: the pure core and the tick's logic do no I/O, and nothing points upward at the
process wiring of ``iw_zenoh/nodes``."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "iw_zenoh"

# what pure code must never import: the bus, the network, the process wiring, clocks, the
# environment, threads, processes, sockets, serial lines
IMPURE = (
    "zenoh",
    "iw_zenoh.bus",
    "iw_zenoh.bus.net",
    "iw_zenoh.nodes",
    "iw_zenoh.launch",
    "iw_zenoh.process",
    "socket",
    "time",
    "os",
    "threading",
    "subprocess",
    "selectors",
    "serial",
)
WIRING = ("iw_zenoh.nodes", "iw_zenoh.launch")


def _modules(*parts: str) -> list[Path]:
    return sorted(p for part in parts for p in (PACKAGE / part).rglob("*.py"))


def _package_of(path: Path) -> str:
    """The package a module belongs to (an ``__init__`` belongs to its own)."""
    return ".".join(path.relative_to(PACKAGE.parent).parts[:-1])


def _imports(path: Path) -> set[str]:
    """Every module ``path`` imports, relative imports resolved, ``from a import b`` as ``a`` and ``a.b``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = _package_of(path).split(".")
                pkg = pkg[: len(pkg) - node.level + 1]
                base = ".".join([*pkg, base] if base else pkg)
            out.add(base)
            out.update(f"{base}.{a.name}" for a in node.names)
    return out


def _hits(path: Path, banned: tuple[str, ...]) -> list[str]:
    return sorted(m for m in _imports(path) if any(m == b or m.startswith(b + ".") for b in banned))


def _name(path: Path) -> str:
    return str(path.relative_to(PACKAGE.parent))


def test_the_layers_have_modules_to_check() -> None:
    assert _modules("core")
    assert _modules("sim")
    assert _modules("record")


@pytest.mark.parametrize("path", _modules("core", "sim"), ids=_name)
def test_pure_code_does_no_io(path: Path) -> None:
    assert _hits(path, IMPURE) == []


@pytest.mark.parametrize("path", _modules("core", "sim", "record"), ids=_name)
def test_nothing_below_the_nodes_imports_them(path: Path) -> None:
    assert _hits(path, WIRING) == []
