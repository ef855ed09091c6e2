"""Fixtures for tests with real processes on a real Zenoh router (loopback only)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from tests.integration.harness import Net
from tests.integration.legacy import LegacyClient

if TYPE_CHECKING:
    from playwright.sync_api import Browser


@pytest.fixture
def net(tmp_path: Path) -> Iterator[Net]:
    """A router on a free loopback port; every process the test spawns is stopped after it."""
    n = Net(tmp_path)
    n.start_router()
    try:
        yield n
    finally:
        n.close()


@pytest.fixture
def clients() -> Iterator[list[LegacyClient]]:
    """Legacy clients of a test, closed after it."""
    made: list[LegacyClient] = []
    yield made
    for c in made:
        c.close()


@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    """Debian's Chromium under Playwright, shared by a module's page tests (imported here only when
    a test asks for it: the other integration tests need no browser)."""
    from tests.integration.browser import chromium  # noqa: PLC0415 - see the docstring

    with chromium() as b:
        yield b
