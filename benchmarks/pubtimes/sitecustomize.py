"""Times every ``ZenohBus.publish`` of a process (``profile_tick.py --publish-times``).

On ``PYTHONPATH``, Python imports this at start-up in every process a benchmark starts; it wraps
the bus's publish to count, per key (robot ids folded to ``*``), the calls, their wall time and
the calling thread's CPU time, and at exit writes them as JSON to
``$IWZ_PUBLISH_TIMES_DIR/<pid>.json``. Never on the product's path.
"""

from __future__ import annotations

import atexit
import json
import os
import re
import sys
import time
from pathlib import Path

OUT = os.environ.get("IWZ_PUBLISH_TIMES_DIR")


def _install(out: Path) -> None:
    from iw_zenoh.bus import ZenohBus

    publish = ZenohBus.publish
    stats: dict[str, list[int]] = {}
    numbers = re.compile(r"/\d+(?=/|$)")

    def timed(self: ZenohBus, key: str, data: bytes) -> None:
        t, c = time.perf_counter_ns(), time.thread_time_ns()
        publish(self, key, data)
        s = stats.setdefault(numbers.sub("/*", key), [0, 0, 0])
        s[0] += 1
        s[1] += time.perf_counter_ns() - t
        s[2] += time.thread_time_ns() - c

    def dump() -> None:
        role = sys.argv[1] if len(sys.argv) > 1 else "?"  # the role: world, sensors, agent ...
        (out / f"{os.getpid()}.json").write_text(json.dumps({"process": role, "keys": stats}))

    ZenohBus.publish = timed  # type: ignore[method-assign]
    atexit.register(dump)


if OUT and "iw_zenoh.cli" in sys.orig_argv:
    _install(Path(OUT))
