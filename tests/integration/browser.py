"""Debian's Chromium, driven by Playwright, for the viewer's browser tests (never a browser
download: the README's test command installs the chromium package)."""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from playwright.sync_api import Browser, sync_playwright

from benchmarks.chromium import CHROMIUM, INSTALL, launch
from tests.integration.harness import Proc


@contextmanager
def chromium() -> Iterator[Browser]:
    """Debian's Chromium under Playwright; fails (never skips) when it is not installed."""
    if not CHROMIUM.exists():
        pytest.fail(
            f"{CHROMIUM} is missing: the viewer's browser tests need Debian's chromium. Install it with "
            f"`{INSTALL}` (the README's test command does)"
        )
    with sync_playwright() as p:
        browser = launch(p)
        try:
            yield browser
        finally:
            browser.close()


def viewer_url(proc: Proc, timeout_s: float = 60.0) -> str:
    """The page's address, as ``iwz view`` prints it once it serves."""
    deadline = time.monotonic() + timeout_s
    while True:
        m = re.search(r"iwz view: (http://\S+/)", proc.output())
        if m:
            return m.group(1)
        assert proc.popen.poll() is None, f"iwz view died:\n{proc.output()}"
        assert time.monotonic() < deadline, f"iwz view did not serve within {timeout_s} s:\n{proc.output()}"
        time.sleep(0.05)  # polling its log: there is no event to wait on
