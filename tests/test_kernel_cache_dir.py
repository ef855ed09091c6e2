"""The compiled kernels are cached in a folder per version of their sources
(``iw_zenoh/kernel_cache.py``): numba checks a cached kernel against its own file only, and a
kernel calling another file's kept that file's old code (a stale ``fused._tick`` would move chairs
by an old ``drive.propose_into`` in ``step_arrays`` and by the new one in ``step``)."""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

from iw_zenoh import kernel_cache

PACKAGE = Path(kernel_cache.__file__).resolve().parent


def _hashed() -> set[Path]:
    return {PACKAGE / name for name in kernel_cache.SOURCES}


def _kernels(tree: ast.Module) -> list[ast.FunctionDef]:
    def compiled(d: ast.expr) -> bool:
        f = d.func if isinstance(d, ast.Call) else d
        return isinstance(f, ast.Name) and f.id == "njit" or isinstance(f, ast.Attribute) and f.attr == "njit"

    return [n for n in tree.body if isinstance(n, ast.FunctionDef) and any(compiled(d) for d in n.decorator_list)]


def _module_file(module: str, name: str) -> Path:
    """The file a name imported ``from module import name`` comes from (a module of a package
    is its own file)."""
    rel = PACKAGE.joinpath(*module.split(".")[1:])
    if (rel / f"{name}.py").exists():
        return rel / f"{name}.py"
    return rel.with_suffix(".py") if rel.with_suffix(".py").exists() else rel / "__init__.py"


def test_every_kernel_and_what_its_body_uses_from_the_package_is_in_the_hashed_sources() -> None:
    hashed = _hashed()
    found = 0
    for f in PACKAGE.rglob("*.py"):
        tree = ast.parse(f.read_text())
        kernels = _kernels(tree)
        if not kernels:
            continue
        found += 1
        assert f in hashed, f"{f.relative_to(PACKAGE)} has compiled kernels but is not in kernel_cache.SOURCES"
        imported = {
            (a.asname or a.name): (n.module, a.name)
            for n in ast.walk(tree)
            if isinstance(n, ast.ImportFrom) and n.module and n.module.startswith("iw_zenoh")
            for a in n.names
        }
        for k in kernels:
            used = {n.id for n in ast.walk(k) if isinstance(n, ast.Name)}
            for name in used & set(imported):
                src = _module_file(*imported[name])
                assert src in hashed, f"{k.name} in {f.name} uses {name} of {src.relative_to(PACKAGE)}, not hashed"
    assert found >= 10  # core's kernels and learn/nav.py's


def test_a_change_to_a_kernels_source_gives_another_folder_and_other_files_do_not(tmp_path: Path) -> None:
    root = tmp_path / "iw_zenoh"
    shutil.copytree(PACKAGE / "core", root / "core", ignore=shutil.ignore_patterns("__pycache__"))
    (root / "learn").mkdir()
    shutil.copy(PACKAGE / "learn" / "nav.py", root / "learn" / "nav.py")
    before = kernel_cache.fingerprint(root)
    assert before == kernel_cache.fingerprint(PACKAGE)  # the same sources, the same folder
    (root / "learn" / "episode.py").write_text("y = 2\n")
    world = root / "core" / "world.py"  # the core's Python, no kernel in it: no recompiling
    world.write_text(world.read_text() + "\n# a change\n")
    assert kernel_cache.fingerprint(root) == before
    for name in ("core/drive.py", "learn/nav.py"):
        f = root / name
        f.write_text(f.read_text() + "\n# a change\n")
        assert kernel_cache.fingerprint(root) != before, name
        before = kernel_cache.fingerprint(root)


def _python(code: str, env: dict[str, str]) -> str:
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=240, check=False
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.strip().splitlines()[-1]


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", kernel_cache.BASE_VAR)}
    return {**env, **extra}


CHILD = """
import os, subprocess, sys
import numba
from iw_zenoh.core import drive
drive._clamp(0.5)  # a small kernel: compiled in a second, cached in the folder
child = subprocess.run([sys.executable, "-c", "import iw_zenoh, numba; print(numba.config.CACHE_DIR)"],
                       capture_output=True, text=True, check=True).stdout.strip()
print(numba.config.CACHE_DIR, child)
"""


def test_a_process_and_its_children_cache_kernels_in_the_folder_of_their_sources(tmp_path: Path) -> None:
    base = tmp_path / "cache"
    mine, child = _python(CHILD, _env(NUMBA_CACHE_DIR=str(base))).split()
    want = base / f"k-{kernel_cache.fingerprint()}"
    assert Path(mine) == want
    assert Path(child) == want  # the child hashed under the same base, not under the folder
    assert list(want.rglob("drive._clamp*.nbi")), "the kernel was not cached in the folder"


def test_old_folders_are_pruned_when_a_new_one_is_made_and_numba_imported_first_is_pointed_too(
    tmp_path: Path,
) -> None:
    base = tmp_path / "cache"
    olds = [f"k-{i:016x}" for i in range(5)]
    for i, name in enumerate(olds):
        d = base / name
        d.mkdir(parents=True)
        os.utime(d, (1_000_000 + i, 1_000_000 + i))
    for other in ("not-a-cache", "k-means_0123abcd"):  # another project's numba folder too
        (base / other).mkdir()
    code = "import numba; import iw_zenoh; print(numba.config.CACHE_DIR)"
    got = Path(_python(code, _env(NUMBA_CACHE_DIR=str(base))))
    assert got == base / f"k-{kernel_cache.fingerprint()}"
    left = sorted(d.name for d in base.iterdir())
    assert left == sorted([olds[3], olds[4], got.name, "not-a-cache", "k-means_0123abcd"])


def test_a_base_that_cannot_be_written_falls_back_to_the_users_cache(tmp_path: Path) -> None:
    blocked = tmp_path / "a-file"  # not a folder: nothing can be made in it (even by root)
    blocked.write_text("")
    code = "import os, iw_zenoh; print(os.environ['NUMBA_CACHE_DIR'])"
    got = Path(_python(code, _env(NUMBA_CACHE_DIR=str(blocked), XDG_CACHE_HOME=str(tmp_path / "xdg"))))
    assert got == tmp_path / "xdg" / "iw_zenoh" / "kernels" / f"k-{kernel_cache.fingerprint()}"
    assert got.is_dir()
