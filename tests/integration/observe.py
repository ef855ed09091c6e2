"""A tiny observer for multi-host tests: prints the ticks and robot positions it sees, as JSON.

python -m tests.integration.observe ENDPOINT SIM LAST_TICK
"""

from __future__ import annotations

import json
import sys

from iw_zenoh import keys
from iw_zenoh.bus import Inbox, ZenohBus
from iw_zenoh.bus.net import NetConfig
from iw_zenoh.messages import WorldState, decode


def main() -> int:
    """Subscribes to state until LAST_TICK, then prints a summary line."""
    endpoint, sim, last = sys.argv[1], sys.argv[2], int(sys.argv[3])
    bus = ZenohBus(NetConfig(connect=(endpoint,)))
    box = Inbox()
    bus.subscribe(keys.state(sim), box)
    print("ready", flush=True)
    ticks: list[int] = []
    first: dict[int, tuple[float, float]] = {}
    final: dict[int, tuple[float, float]] = {}
    while True:
        d = box.get(timeout_s=60)
        if d is None:
            break
        m = decode(d[1], WorldState)
        ticks.append(m.tick)
        for rid, x, y in zip(m.ids, m.x, m.y, strict=True):
            first.setdefault(rid, (x, y))
            final[rid] = (x, y)
        if m.tick >= last:
            break
    print(json.dumps({"ticks": ticks, "first": first, "final": final}), flush=True)
    bus.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
