"""iw-zenoh: a distributed intelligent-wheelchair simulator on Eclipse Zenoh."""

from __future__ import annotations

from iw_zenoh import kernel_cache

try:
    kernel_cache.configure()  # before any kernel is compiled or loaded (its module doc says why)
except Exception as e:  # noqa: BLE001 (the package must import: numba's own cache choice then)
    import warnings

    warnings.warn(f"iw_zenoh: the kernels' cache folder was not set ({e})", RuntimeWarning, stacklevel=1)

__version__ = "0.1.0"

__all__ = ["__version__"]
