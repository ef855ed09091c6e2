"""The web viewer (``iwz view``): the page's server, its feed of the world, and the page itself
(``static/``: plain JS modules, no build step, nothing from a CDN)."""

from __future__ import annotations

__all__: list[str] = []
