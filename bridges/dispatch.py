"""``iwz bridge ciberrato|serial``: routes to the bridge named."""

from __future__ import annotations

import importlib
from collections.abc import Sequence

__all__ = ["BRIDGES", "main"]

BRIDGES = {"ciberrato": "iw_zenoh.bridges.ciberrato.app", "serial": "iw_zenoh.bridges.serial.node"}


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the bridge named by the first argument (its node's ``main`` gets every argument)."""
    args = list(argv or [])
    if args[:1] == ["serial"]:
        code = importlib.import_module(BRIDGES["serial"]).main(args)
        return int(code)
    if args[:1] in ([], ["-h"], ["--help"]):
        print("usage: iwz bridge ciberrato|serial [options]   (iwz bridge NAME --help)")
        return 0 if args else 2
    code = importlib.import_module(BRIDGES["ciberrato"]).main(args)
    return int(code)
