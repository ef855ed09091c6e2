"""The code keeps its shape: no function over 60 lines, except compiled (numba) kernels, whose
loops are kept whole so numba can compile them as one."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("iw_zenoh", "agents", "bridges")
MAX_LINES = 60
COMPILERS = frozenset({"njit", "jit"})  # numba's decorators that compile a function


def _modules() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def _numba_names(tree: ast.Module) -> tuple[set[str], set[str]]:
    """The local names bound to numba's compilers (``from numba import njit``, aliases included)
    and to the numba module itself (``import numba as nb``)."""
    compilers: set[str] = set()
    modules: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module == "numba":
            compilers.update(a.asname or a.name for a in node.names if a.name in COMPILERS)
        elif isinstance(node, ast.Import):
            modules.update(a.asname or a.name for a in node.names if a.name == "numba")
    return compilers, modules


def _compiled(fn: ast.FunctionDef | ast.AsyncFunctionDef, compilers: set[str], modules: set[str]) -> bool:
    """Whether a decorator of ``fn`` is numba's ``njit`` or ``jit``, called or not."""
    for dec in fn.decorator_list:
        target = dec.func if isinstance(dec, ast.Call) else dec
        if isinstance(target, ast.Name) and target.id in compilers:
            return True
        if (
            isinstance(target, ast.Attribute)
            and target.attr in COMPILERS
            and isinstance(target.value, ast.Name)
            and target.value.id in modules
        ):
            return True
    return False


def _long_functions(path: Path, root: Path = ROOT) -> tuple[list[str], list[str]]:
    """``path:line name length`` (path relative to ``root``) of every function over
    :data:`MAX_LINES` lines (``def`` to its last line), split into (not compiled, compiled)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    compilers, modules = _numba_names(tree)
    long_ones: list[str] = []
    kernels: list[str] = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        length = (node.end_lineno or node.lineno) - node.lineno + 1
        if length > MAX_LINES:
            where = f"{path.relative_to(root)}:{node.lineno} {node.name} {length}"
            (kernels if _compiled(node, compilers, modules) else long_ones).append(where)
    return long_ones, kernels


def test_there_are_modules_to_measure() -> None:
    names = {str(p.relative_to(ROOT)) for p in _modules()}
    assert {"iw_zenoh/core/sensors.py", "agents/autopilot.py", "bridges/ciberrato/codec.py"} <= names


def test_no_function_is_over_60_lines_outside_compiled_kernels() -> None:
    offenders = [where for path in _modules() for where in _long_functions(path)[0]]
    assert offenders == [], "split these functions (path:line name lines):\n" + "\n".join(offenders)


def test_the_exemption_is_for_numba_kernels_only(tmp_path: Path) -> None:
    body = "".join(f"    x = {i}\n" for i in range(MAX_LINES))
    src = tmp_path / "m.py"
    src.write_text(
        "import numba as nb\nfrom numba import njit as compile_me\nfrom functools import cache as njit\n\n"
        f"@compile_me(cache=True)\ndef kernel():\n{body}\n"
        f"@nb.jit\ndef other_kernel():\n{body}\n"
        f"@njit\ndef cached():\n{body}\n"
        f"def plain():\n{body}\n"
        f"def short():\n    return 1\n",
        encoding="utf-8",
    )
    long_ones, kernels = _long_functions(src, tmp_path)
    assert [w.split()[1] for w in kernels] == ["kernel", "other_kernel"]
    assert [w.split()[1] for w in long_ones] == ["cached", "plain"]
