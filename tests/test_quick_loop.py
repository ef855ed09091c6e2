"""The quick loop (``tests/support/quick.py``): ``-m "not slow"`` runs each property test with at most
``QUICK_EXAMPLES`` examples, while the full suite keeps every test's own count."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.support import quick as quick_loop


def _config(markexpr: str) -> pytest.Config:
    return SimpleNamespace(getoption=lambda name, default=None: markexpr if name == "markexpr" else default)  # type: ignore[return-value]


def _property_test(examples: int) -> tuple[Callable[[], None], list[int]]:
    seen: list[int] = []

    @settings(max_examples=examples, database=None)
    @given(st.integers())
    def prop(n: int) -> None:
        seen.append(n)

    return prop, seen


@pytest.mark.parametrize(
    ("markexpr", "env", "expected"),
    [
        ("not slow", None, True),
        ("not slow and not zenoh", None, True),
        ("(not  slow)", None, True),
        ("", None, False),
        ("slow", None, False),
        ("zenoh", None, False),
        ("not slowly", None, False),
        ("not slow or zenoh", None, False),
        ("not (slow or zenoh)", None, True),
        ("zenoh and not slow", None, True),
        ("not slow(reason=1)", None, False),
        ("not slow", "0", False),
        ("", "1", True),
    ],
)
def test_a_run_is_the_quick_loop_when_its_marker_expression_leaves_out_slow_or_iwz_quick_says_so(
    monkeypatch: pytest.MonkeyPatch, markexpr: str, env: str | None, expected: bool
) -> None:
    if env is None:
        monkeypatch.delenv("IWZ_QUICK", raising=False)
    else:
        monkeypatch.setenv("IWZ_QUICK", env)
    assert quick_loop.quick(_config(markexpr)) is expected


def test_a_quick_loop_leaves_the_integration_tests_uncollected_and_a_full_run_collects_them(
    request: pytest.FixtureRequest,
) -> None:
    hook = request.config.hook.pytest_ignore_collect  # the conftest's hook, as pytest calls it
    integration = Path(__file__).resolve().parent / "integration"
    assert (integration / "harness.py").exists()
    assert quick_loop.uncollected(integration, _config("not slow"))
    assert quick_loop.uncollected(integration, _config("(not slow) and not zenoh"))
    assert not quick_loop.uncollected(integration, _config(""))
    assert not quick_loop.uncollected(integration, _config("not slow or zenoh"))
    assert not quick_loop.uncollected(integration.parent / "core", _config("not slow"))
    this_run = hook(collection_path=integration, config=request.config)
    assert (this_run is True) == quick_loop.leaves_out_slow(request.config)


def test_the_quick_loop_caps_a_property_tests_own_examples_and_keeps_its_other_settings() -> None:
    prop, seen = _property_test(300)
    quick_loop.fewer_examples(SimpleNamespace(obj=prop))  # type: ignore[arg-type]
    prop()
    assert 0 < len(seen) <= quick_loop.QUICK_EXAMPLES
    kept = prop._hypothesis_internal_use_settings  # type: ignore[attr-defined]
    assert kept.database is None  # the test's own setting, still there


def test_outside_the_quick_loop_a_property_test_runs_all_its_examples() -> None:
    prop, seen = _property_test(150)
    prop()
    assert len(seen) >= 150


def test_a_property_test_asking_for_fewer_examples_than_the_cap_keeps_its_count() -> None:
    prop, seen = _property_test(3)
    quick_loop.fewer_examples(SimpleNamespace(obj=prop))  # type: ignore[arg-type]
    assert prop._hypothesis_internal_use_settings.max_examples == 3  # type: ignore[attr-defined]
    prop()
    assert 0 < len(seen) <= 3


def test_this_run_uses_the_profile_its_marker_expression_asks_for(request: pytest.FixtureRequest) -> None:
    expected = "quick" if quick_loop.quick(request.config) else "ci"
    assert settings.default == settings.get_profile(expected)
