"""Threads the in-process simulation may use, kept out of the pure core: small pools started on
first use, and a process forked while they work is made safe.

:class:`~iw_zenoh.core.noise.NoiseStreams` draws a many-robot roster's normals in runs on
:func:`run_all` and its next block ahead on :func:`submit_ahead` (numpy's draws release the GIL;
each robot has its own generator, so the values do not depend on the threads). Only the learning
environments ask for threads (``LocalWorld(threads=N)``); the distributed roles run on their own.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor, wait
from functools import lru_cache
from typing import Any, TypeVar

__all__ = ["run_all", "submit_ahead"]

T = TypeVar("T")


@lru_cache(maxsize=4)
def _pool(threads: int) -> ThreadPoolExecutor:
    """``threads - 1`` threads (the caller runs one part too), started on first use."""
    return ThreadPoolExecutor(max_workers=threads - 1, thread_name_prefix="iwz-runs")


@lru_cache(maxsize=1)
def _ahead() -> ThreadPoolExecutor:
    """The one thread work drawn ahead runs on, started on first use."""
    return ThreadPoolExecutor(max_workers=1, thread_name_prefix="iwz-ahead")


_PENDING: set[Future[Any]] = set()  # work submitted ahead, not done yet (a fork waits for it)


def run_all(fn: Callable[[T], None], parts: Sequence[T]) -> None:
    """``fn(part)`` for every part, the first on the caller's thread and the others on a pool
    of ``len(parts) - 1`` threads; returns when every one has ended, then raises the first
    failure, if any (none is left running behind it)."""
    done = [_pool(len(parts)).submit(fn, p) for p in parts[1:]]
    try:
        fn(parts[0])
    finally:
        wait(done)
    for f in done:
        f.result()


def submit_ahead(fn: Callable[..., T], *args: object) -> Future[T]:
    """``fn(*args)`` on the thread for work drawn ahead, while the caller goes on."""
    f = _ahead().submit(fn, *args)
    _PENDING.add(f)
    f.add_done_callback(_PENDING.discard)
    return f


def _before_fork() -> None:
    """A process forked while work runs ahead would wait for it for ever (its copy of the pool
    has no thread), and what the work writes could be copied half written: finish it first."""
    wait(list(_PENDING))


def _after_fork_in_child() -> None:
    """The child's pools are copies without their threads: it starts its own."""
    _pool.cache_clear()
    _ahead.cache_clear()
    _PENDING.clear()


os.register_at_fork(before=_before_fork, after_in_child=_after_fork_in_child)
