"""Where the compiled kernels are cached on disk: one folder per version of their sources.

numba checks a cached kernel against the time stamp of its own file only. A kernel that calls
kernels of other files (``core/read_all.py``, ``core/fused.py``) holds their code in its cache,
so when only they change it goes on running their old code: after a ``git pull`` into an
editable install (the README's), ``LocalWorld.step_arrays`` could have moved chairs by
yesterday's physics and ``LocalWorld.step`` by today's. So the package's import hashes the
kernels' sources (:data:`SOURCES`: about 1 ms) and points numba's cache at a folder named by the
hash: any change to any kernel compiles them all once, and nothing stale is ever loaded.

The folders live under ``NUMBA_CACHE_DIR`` when it is set, else beside the package
(``iw_zenoh/__pycache__/kernels``) when that is writable, else in the user's cache
(``~/.cache/iw_zenoh/kernels``, ``XDG_CACHE_HOME``). The :data:`KEPT` newest are kept.
Processes started from this one inherit the same folder (``NUMBA_CACHE_DIR``) and the base
(``IWZ_KERNEL_CACHE_BASE``).
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

__all__ = ["KEPT", "SOURCES", "configure", "fingerprint"]

SOURCES = ("core/*.py", "learn/nav.py")  # the kernels and what they import (tests/test_kernel_cache_dir.py)
KEPT = 3  # cache folders kept under the base: the newest
BASE_VAR = "IWZ_KERNEL_CACHE_BASE"
_PREFIX = "k-"
_PACKAGE = Path(__file__).resolve().parent


def fingerprint(root: Path = _PACKAGE) -> str:
    """A hash of the kernels' sources under ``root`` (the package): their paths and contents."""
    h = hashlib.blake2b(digest_size=8)
    for pattern in SOURCES:
        for f in sorted(root.glob(pattern)):
            h.update(f.relative_to(root).as_posix().encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def _base() -> Path:
    """Where the cache folders go (see the module doc)."""
    ours, numba_dir = os.environ.get(BASE_VAR), os.environ.get("NUMBA_CACHE_DIR")
    if numba_dir and not (ours and Path(numba_dir).parent == Path(ours) and Path(numba_dir).name.startswith(_PREFIX)):
        return Path(numba_dir)  # the user's (a process started from ours with its own NUMBA_CACHE_DIR too)
    if ours:
        return Path(ours)  # a process started from ours: the same base
    here = _PACKAGE / "__pycache__"
    if os.access(_PACKAGE, os.W_OK) and (not here.exists() or os.access(here, os.W_OK)):
        return here / "kernels"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "iw_zenoh" / "kernels"


def configure() -> Path:
    """Points numba's cache at this version's folder (before any kernel is compiled or loaded:
    the package's import calls it) and returns the folder."""
    base = _base()
    target = base / f"{_PREFIX}{fingerprint()}"
    os.environ[BASE_VAR] = str(base)  # children hash again under the same base, not under target
    os.environ["NUMBA_CACHE_DIR"] = str(target)
    numba = sys.modules.get("numba")
    if numba is not None:  # imported already: its configuration read the environment then
        numba.config.CACHE_DIR = str(target)
    if not target.exists():
        _prune(base)
    return target


def _prune(base: Path) -> None:
    """Removes all but the newest :data:`KEPT` - 1 cache folders under ``base`` (a new one is coming)."""
    try:
        old = sorted(
            (d for d in base.iterdir() if d.is_dir() and d.name.startswith(_PREFIX)),
            key=lambda d: d.stat().st_mtime,
            reverse=True,
        )
    except OSError:  # no base yet, or not readable: nothing to prune
        return
    import shutil  # noqa: PLC0415 (rarely needed: not paid by every process's import)

    for d in old[KEPT - 1 :]:
        shutil.rmtree(d, ignore_errors=True)
