"""iw-zenoh: a distributed intelligent-wheelchair simulator on Eclipse Zenoh."""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["__version__"]
