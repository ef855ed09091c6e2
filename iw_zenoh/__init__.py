"""iw-zenoh: a distributed intelligent-wheelchair simulator on Eclipse Zenoh."""

from __future__ import annotations

from iw_zenoh import kernel_cache

kernel_cache.configure()  # before any kernel is compiled or loaded (its module doc says why)

__version__ = "0.1.0"

__all__ = ["__version__"]
