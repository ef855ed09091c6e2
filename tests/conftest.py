"""Shared fixtures (a seeded generator, a small map and its scene), the ``slow`` marker on every test
that starts processes, the kernels warmed for those, and the quick hypothesis profile of the quick
loop; the builders tests share are in ``tests/support/builders.py``, their fakes in
``tests/support/fakes.py``."""

from __future__ import annotations

import inspect
import os
import subprocess
from collections.abc import Iterator
from pathlib import Path
from types import CodeType, ModuleType

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

from iw_zenoh.core.lab import Lab, Scene
from tests.support import quick as quick_loop
from tests.support.builders import box_wall

settings.register_profile("ci", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("ci")
quick_loop.register("ci")  # the quick loop's profile: "ci" with fewer examples


TESTS = Path(__file__).resolve().parent
# what a test module that starts processes holds: the modules (or their names) it starts them with
PROCESS_STARTERS = frozenset({"subprocess", "multiprocessing", "tests.integration.harness"})
_warm: list[bool] = []
CHECKS = frozenset({"_kernels_for_processes", "_no_process_unless_slow"})  # this file's own, on every test


def _starter(value: object) -> bool:
    name = value.__name__ if isinstance(value, ModuleType) else getattr(value, "__module__", None)
    return name in PROCESS_STARTERS


def _codes(code: CodeType) -> Iterator[CodeType]:
    """A code object and every one nested in it (its lambdas, comprehensions, inner functions)."""
    yield code
    for const in code.co_consts:
        if isinstance(const, CodeType):
            yield from _codes(const)


def _reaches_a_starter(fn: object, seen: set[int]) -> bool:
    """Whether ``fn`` (a function or a class of the tests), or what of the tests it calls, uses a
    process starter."""
    if id(fn) in seen:
        return False
    seen.add(id(fn))
    if isinstance(fn, type):
        return any(_reaches_a_starter(v, seen) for v in vars(fn).values() if inspect.isfunction(v))
    fn = inspect.unwrap(fn) if callable(fn) else fn
    code, scope = getattr(fn, "__code__", None), getattr(fn, "__globals__", None)
    if code is None or scope is None:
        return False
    for name in {n for c in _codes(code) for n in c.co_names}:
        value = scope.get(name)
        if value is None:
            continue
        if _starter(value):
            return True
        ours = inspect.isfunction(value) or isinstance(value, type)
        if ours and str(value.__module__).startswith("tests") and _reaches_a_starter(value, seen):
            return True
    return False


def _starts_processes(item: pytest.Item) -> bool:
    """Whether a test starts processes: it is an integration test, carries the ``zenoh`` marker, or
    its function or one of its fixtures (or a helper of the tests they call) uses ``subprocess``,
    ``multiprocessing`` or the integration harness."""
    if "integration" in Path(str(item.path)).resolve().relative_to(TESTS).parts:
        return True
    if item.get_closest_marker("zenoh") is not None:
        return True
    seen: set[int] = set()
    if _reaches_a_starter(getattr(item, "function", None), seen):
        return True
    info = getattr(item, "_fixtureinfo", None)
    defs = info.name2fixturedefs.values() if info is not None else ()
    return any(_reaches_a_starter(d[-1].func, seen) for d in defs if d and d[-1].argname not in CHECKS)


def pytest_configure(config: pytest.Config) -> None:
    """The quick loop loads the quick hypothesis profile (``tests/support/quick.py``)."""
    if quick_loop.quick(config):
        settings.load_profile("quick")


def pytest_ignore_collect(collection_path: Path, config: pytest.Config) -> bool | None:
    """A run whose marker expression leaves out every ``slow`` test does not import
    ``tests/integration/``: every test there is ``slow`` (``_starts_processes``)."""
    return True if quick_loop.uncollected(collection_path, config) else None


def pytest_report_header(config: pytest.Config) -> str | None:
    """Says when the property tests run the quick loop's few examples."""
    if quick_loop.quick(config):
        return f"quick loop: at most {quick_loop.QUICK_EXAMPLES} hypothesis examples per test (IWZ_QUICK=0: all)"
    return None


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Every test that starts processes is ``slow``: ``pytest -m "not slow"`` is the quick loop,
    where property tests try fewer examples."""
    fast = quick_loop.quick(config)
    for item in items:
        if _starts_processes(item):
            item.add_marker(pytest.mark.slow)
        if fast:
            quick_loop.fewer_examples(item)


@pytest.fixture(autouse=True)
def _kernels_for_processes(request: pytest.FixtureRequest) -> None:
    """Compiles the proximity and contact kernels once, before the first test that starts processes
    (a sensors or collision process or an agent that plans would otherwise each compile them, for
    seconds, in a fresh checkout); a quick run (``-m "not slow"``) compiles only what its tests call."""
    if not _warm and request.node.get_closest_marker("slow") is not None:
        from iw_zenoh.core import cones, contact  # here: collection and a quick run need not import numba

        cones.warm_up()
        contact.warm_up()
        _warm.append(True)


@pytest.fixture(autouse=True)
def _no_process_unless_slow(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> None:
    """With ``IWZ_CHECK_SLOW=1``, a test not marked ``slow`` that starts a process fails, naming it:
    the check that the ``slow`` marker is on every test that starts processes."""
    if os.environ.get("IWZ_CHECK_SLOW") != "1" or request.node.get_closest_marker("slow") is not None:
        return

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError(f"{request.node.nodeid} starts a process ({args[:1]}) but is not marked slow")

    monkeypatch.setattr(subprocess.Popen, "__init__", refuse)


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator, the same in every run."""
    return np.random.default_rng(20261122)


@pytest.fixture
def small_map() -> Lab:
    """A 10 x 6 lab with one 1 x 1 pillar at (5..6, 2..3)."""
    return Lab("small", 10.0, 6.0, (box_wall(5.0, 2.0, 6.0, 3.0),))


@pytest.fixture
def small_scene(small_map: Lab) -> Scene:
    """The small map's geometry."""
    return Scene(small_map)
