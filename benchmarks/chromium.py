"""Debian's Chromium, headless with software WebGL, as the viewer's browser tests and
benchmarks/viewer.py both drive it (one place for its path and flags: the two had copies).

Here rather than in ``iw_zenoh/viewer/``: the product only serves the page, it never starts a
browser; starting one is what the tests and the benchmark do. Plain data and one function, no
pytest, no Playwright at import, so either side imports it cheaply.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Playwright

__all__ = ["CHROMIUM", "FLAGS", "INSTALL", "hooked", "launch"]

CHROMIUM = Path("/usr/bin/chromium")
# as the machine's notes say works headless here, plus software WebGL so the 3D view renders
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
)
INSTALL = "apt-get update -q && apt-get install -y -q chromium"


def hooked(url: str) -> str:
    """The page's address with ``hooks=1``: the page then loads ``hooks.js`` and gives scripts
    ``window.iwz`` (its world, map <-> screen, what it drew and sent); without it the page has no
    test or benchmark hook.

    Example:
        >>> hooked("http://127.0.0.1:8080/?key=abc")
        'http://127.0.0.1:8080/?key=abc&hooks=1'
    """
    return f"{url}{'&' if '?' in url else '?'}hooks=1"


def launch(pw: Playwright) -> Browser:
    """Debian's Chromium (never a browser download) with the flags above.

    Args:
        pw: A started Playwright, e.g. from ``sync_playwright()``.

    Returns:
        The browser; the caller closes it.

    Example:
        >>> with sync_playwright() as pw:  # doctest: +SKIP
        ...     browser = launch(pw)
    """
    return pw.chromium.launch(executable_path=str(CHROMIUM), args=list(FLAGS), headless=True)
