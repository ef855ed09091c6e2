"""Stamps what each process of a benchmark run does in a tick (``benchmarks/tickline.py``).

On ``PYTHONPATH``, Python imports this at start-up in every process a benchmark starts; when
``IWZ_TICKLINE_DIR`` is set it wraps, in ``iwz`` role processes only, the moments a tick is made
of and notes each with ``time.perf_counter_ns()`` (CLOCK_MONOTONIC: one clock for every process
of the machine):

* ``P``/``p`` a publish begins/returns (``ZenohBus.publish``), with its key
* ``R`` a delivery reaches an inbox on Zenoh's callback thread (``Inbox.put``), with its key
* ``D`` a loop drains deliveries of a key (``Inbox.drain``)
* ``A``/``a`` the sensors begin/end computing a tick's readings ahead from its proposal

At exit it writes them as JSON to ``$IWZ_TICKLINE_DIR/<name>-<pid>.json``. Never on the
product's path.
"""

from __future__ import annotations

import atexit
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

OUT = os.environ.get("IWZ_TICKLINE_DIR")


def _install(out: Path) -> None:
    from iw_zenoh.bus import Inbox, ZenohBus
    from iw_zenoh.sim.sensors import SensorsNode

    stamps: list[tuple[int, str, str]] = []
    note = stamps.append
    now = time.perf_counter_ns
    publish, put, drain, ahead = ZenohBus.publish, Inbox.put, Inbox.drain, SensorsNode.ahead

    def stamped_publish(self: ZenohBus, key: str, data: bytes) -> None:
        note((now(), "P", key))
        publish(self, key, data)
        note((now(), "p", key))

    def stamped_put(self: Inbox, item: Any) -> None:
        note((now(), "R", item[0]))
        put(self, item)

    def stamped_drain(self: Inbox) -> Any:
        got = drain(self)
        if got:
            note((now(), "D", got[-1][0]))
        return got

    def stamped_ahead(self: SensorsNode, *args: Any) -> Any:
        note((now(), "A", "ahead"))
        try:
            return ahead(self, *args)
        finally:
            note((now(), "a", "ahead"))

    ZenohBus.publish = stamped_publish  # type: ignore[method-assign]
    Inbox.put = stamped_put  # type: ignore[method-assign]
    Inbox.drain = stamped_drain  # type: ignore[method-assign]
    SensorsNode.ahead = stamped_ahead  # type: ignore[method-assign,assignment]

    def dump() -> None:
        argv = sys.argv
        name = argv[argv.index("--name") + 1] if "--name" in argv[:-1] else argv[1] if len(argv) > 1 else "?"
        (out / f"{name}-{os.getpid()}.json").write_text(json.dumps(stamps))

    atexit.register(dump)


if OUT and "iw_zenoh.cli" in sys.orig_argv:
    _install(Path(OUT))
