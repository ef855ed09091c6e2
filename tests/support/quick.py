"""The quick loop (``pytest -m "not slow"``, or ``IWZ_QUICK=1``): property tests try at most
``QUICK_EXAMPLES`` examples each, and a run whose marker expression leaves out every ``slow`` test
does not import ``tests/integration/`` (all of it is ``slow``) only to deselect it. The full suite
(what CI runs) keeps the default profile and each test's own ``max_examples``; ``IWZ_QUICK=0``
keeps them in the quick loop too."""

from __future__ import annotations

import itertools
import os
from pathlib import Path

import pytest
from _pytest.mark.expression import Expression
from hypothesis import settings

QUICK_EXAMPLES = 10
INTEGRATION = Path(__file__).resolve().parents[1] / "integration"  # every test there starts processes


class _Kwargs(Exception):
    """A marker with arguments in the expression (``slow(reason=...)``): not a plain ``not slow``."""


def _has(marks: set[str]) -> object:
    def matcher(name: str, /, **kwargs: object) -> bool:
        if kwargs:
            raise _Kwargs(name)
        return name in marks

    return matcher


def leaves_out_slow(config: pytest.Config) -> bool:
    """Whether the run's marker expression (``-m``) is false for every test marked ``slow``, whatever
    its other markers: ``not slow`` and ``not slow and not zenoh`` are, ``not slow or zenoh`` is not."""
    text = str(config.getoption("markexpr", "") or "").strip()
    if not text:
        return False
    try:
        expr = Expression.compile(text)
    except SyntaxError:
        return False  # pytest itself says what is wrong with it
    others = sorted(expr.idents() - {"slow"})
    if len(others) > 8:
        return False
    for values in itertools.product((False, True), repeat=len(others)):
        marks = {"slow", *(name for name, on in zip(others, values, strict=True) if on)}
        try:
            if expr.evaluate(_has(marks)):  # type: ignore[arg-type]
                return False
        except _Kwargs:
            return False
    return True


def uncollected(path: Path, config: pytest.Config) -> bool:
    """Whether to leave ``path`` uncollected: ``tests/integration/`` in a run that leaves out every
    ``slow`` test (it would import 50-odd modules, playwright among them, only to deselect them)."""
    return path == INTEGRATION and leaves_out_slow(config)


def quick(config: pytest.Config) -> bool:
    """Whether this run is the quick loop: ``IWZ_QUICK=1``, or its marker expression leaves out
    ``slow`` (``-m "not slow"``) and ``IWZ_QUICK`` is not ``0``."""
    asked = os.environ.get("IWZ_QUICK", "")
    if asked in ("0", "1"):
        return asked == "1"
    return leaves_out_slow(config)


def register(parent: str) -> None:
    """Registers the ``quick`` hypothesis profile: ``parent``'s settings with fewer examples."""
    settings.register_profile("quick", parent=settings.get_profile(parent), max_examples=QUICK_EXAMPLES)


def fewer_examples(item: pytest.Item) -> None:
    """Caps a property test's own ``max_examples`` (``@settings(max_examples=300)``, which a profile
    cannot lower) at ``QUICK_EXAMPLES``, keeping its other settings: hypothesis's own pytest plugin
    replaces a test's settings the same way for parametrized tests."""
    fn = getattr(item, "obj", None)
    fn = getattr(fn, "__func__", fn)
    own = getattr(fn, "_hypothesis_internal_use_settings", None)
    if getattr(fn, "is_hypothesis_test", False) and isinstance(own, settings) and own.max_examples > QUICK_EXAMPLES:
        fn._hypothesis_internal_use_settings = settings(own, max_examples=QUICK_EXAMPLES)  # type: ignore[union-attr]
