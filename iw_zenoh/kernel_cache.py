"""Where the compiled kernels are cached on disk: one folder per version of their sources.

numba checks a cached kernel against the time stamp of its own file only. A kernel that calls
kernels of other files (``core/read_all.py``, ``core/fused.py``) holds their code in its cache,
so when only they change it goes on running their old code: after a ``git pull`` into an
editable install (the README's), ``LocalWorld.step_arrays`` could have moved chairs by
yesterday's physics and ``LocalWorld.step`` by today's. So the package's import hashes the
kernels' sources and what their bodies use (:data:`SOURCES`: under a millisecond) and points
numba's cache at a folder named by the hash: any change to them compiles every kernel once, and
nothing stale is ever loaded.

The folders live under ``NUMBA_CACHE_DIR`` when it is set, else beside the package
(``iw_zenoh/__pycache__/kernels``); when that cannot be written, in the user's cache
(``~/.cache/iw_zenoh/kernels``, ``XDG_CACHE_HOME``), else in the temporary folder. The
:data:`KEPT` most recently used are kept.
Processes started from this one inherit the same folder (``NUMBA_CACHE_DIR``) and the base
(``IWZ_KERNEL_CACHE_BASE``).
"""

from __future__ import annotations

import hashlib
import os
import re
import sys
import warnings
from collections.abc import Iterator
from pathlib import Path

__all__ = ["KEPT", "SOURCES", "configure", "fingerprint"]

# the files of the compiled kernels and of what their bodies use (tests/test_kernel_cache_dir.py)
SOURCES = (
    "core/cellgrid.py",
    "core/collide.py",
    "core/cones.py",
    "core/contact.py",
    "core/drive.py",
    "core/fused.py",
    "core/laser.py",
    "core/motor.py",
    "core/placing.py",
    "core/read_all.py",
    "core/readout.py",
    "learn/nav.py",
)
KEPT = 3  # cache folders kept under a base: the newest
BASE_VAR = "IWZ_KERNEL_CACHE_BASE"
_FOLDER = re.compile(r"k-[0-9a-f]{16}")  # a cache folder's name: k- and the fingerprint
_PACKAGE = Path(__file__).resolve().parent


def fingerprint(root: Path = _PACKAGE) -> str:
    """A hash of the kernels' sources under ``root`` (the package): their paths and contents."""
    h = hashlib.blake2b(digest_size=8)
    for name in SOURCES:
        f = root / name
        h.update(name.encode())
        h.update(f.read_bytes() if f.exists() else b"")
    return h.hexdigest()


def _bases() -> Iterator[Path]:
    """Where the cache folders may go, in order (see the module doc): the first writable is taken."""
    ours, numba_dir = os.environ.get(BASE_VAR), os.environ.get("NUMBA_CACHE_DIR")
    if numba_dir and not (ours and Path(numba_dir).parent == Path(ours) and _FOLDER.fullmatch(Path(numba_dir).name)):
        yield Path(os.path.abspath(numba_dir))  # the user's (also set for a process started from ours)
    elif ours:
        yield Path(ours)  # a process started from ours: the same base
    else:
        yield _PACKAGE / "__pycache__" / "kernels"
    home = os.environ.get("XDG_CACHE_HOME")
    if not home:
        try:
            home = str(Path.home() / ".cache")
        except RuntimeError:  # no home (an arbitrary user id in a container)
            home = None
    if home:
        yield Path(home) / "iw_zenoh" / "kernels"
    import tempfile  # noqa: PLC0415 (the last resort: not paid by every process's import)

    user = os.getuid() if hasattr(os, "getuid") else os.getpid()
    yield Path(tempfile.gettempdir()) / f"iw_zenoh-kernels-{user}"


def _writable(folder: Path) -> bool:
    """Whether ``folder`` is (made and) writable: a file is made in it and removed (``os.access``
    is not enough on Windows, nor for a folder another user made)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / f".probe-{os.getpid()}"
        os.close(os.open(probe, os.O_CREAT | os.O_WRONLY | os.O_TRUNC, 0o600))
        probe.unlink()
        os.utime(folder)  # used now: the pruning keeps the newest used
    except OSError:
        return False
    return True


def configure() -> Path | None:
    """Points numba's cache at this version's folder (before any kernel is compiled or loaded:
    the package's import calls it) and returns the folder; None when no place is writable
    (numba's own choice then, with a warning)."""
    name = f"k-{fingerprint()}"
    for base in _bases():
        target = base / name
        new = not target.exists()
        if not _writable(target):
            continue
        os.environ[BASE_VAR] = str(base)  # children hash again under the same base, not under target
        os.environ["NUMBA_CACHE_DIR"] = str(target)
        numba = sys.modules.get("numba")
        if numba is not None:  # imported already: its configuration read the environment then
            numba.config.CACHE_DIR = str(target)
        if new:
            _prune(base, target)
        return target
    warnings.warn(
        "iw_zenoh: no writable folder for the compiled kernels' cache (set NUMBA_CACHE_DIR to one); "
        "numba's own cache may hold kernels compiled from older sources",
        RuntimeWarning,
        stacklevel=2,
    )
    return None


def _prune(base: Path, keep: Path) -> None:
    """Removes all but the newest :data:`KEPT` cache folders under ``base`` (``keep`` among them)."""
    try:
        old = sorted(
            (d for d in base.iterdir() if d != keep and d.is_dir() and _FOLDER.fullmatch(d.name)),
            key=lambda d: d.stat().st_mtime,
            reverse=True,
        )
    except OSError:  # not readable: nothing to prune
        return
    import shutil  # noqa: PLC0415 (rarely needed: not paid by every process's import)

    for d in old[KEPT - 1 :]:
        shutil.rmtree(d, ignore_errors=True)
