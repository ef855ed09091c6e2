"""``iwz radio``: robot-to-robot messages, delivered only within range.

Defaults follow Ciber-Rato DCOSS: 8 m range, at most 100 bytes a message, at most 400 bytes
heard per robot per tick; a message said during tick n is heard in tick n+1 by every robot
(the speaker included) whose centre is closer than the range, in sender order. What is dropped
(too long, over a robot's budget, from an unknown robot) is counted in a ``radio-dropped`` event.
"""

from __future__ import annotations

import argparse
import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from iw_zenoh import keys
from iw_zenoh.bus import Bus
from iw_zenoh.messages import (
    EventKind,
    Hear,
    Heard,
    Outgoing,
    RadioBatch,
    RadioDroppedData,
    Say,
    WorldState,
    make_event,
)
from iw_zenoh.runtime import NodeIO, start_role

__all__ = ["RadioConfig", "RadioNode", "main", "run"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class RadioConfig:
    """Radio limits."""

    range_m: float = 8.0
    max_message_bytes: int = 100
    max_heard_bytes: int = 400


class RadioNode:
    """Collects says and delivers them on the next state (logic only)."""

    def __init__(self, sim: str, cfg: RadioConfig | None = None) -> None:
        self.sim = sim
        self.cfg = cfg or RadioConfig()
        self._said: dict[int, str] = {}
        self._dropped: dict[str, int] = {}

    def on_say(self, msg: Say) -> None:
        """Keeps a robot's latest message of this tick (one per robot, the last wins)."""
        if len(msg.text.encode("utf-8")) > self.cfg.max_message_bytes:
            self._dropped["too_long"] = self._dropped.get("too_long", 0) + 1
            return
        self._said[msg.robot_id] = msg.text

    def on_state(self, msg: WorldState) -> list[Outgoing]:
        """Delivers what was said since the last state."""
        said, self._said = self._said, {}
        dropped, self._dropped = self._dropped, {}
        index = {rid: i for i, rid in enumerate(msg.ids)}
        xy = np.column_stack([msg.x, msg.y]) if msg.ids else np.zeros((0, 2))
        hear: dict[int, list[Heard]] = {}
        budget = dict.fromkeys(msg.ids, self.cfg.max_heard_bytes)
        for sender in sorted(said):
            if sender not in index:
                dropped["unknown_sender"] = dropped.get("unknown_sender", 0) + 1
                continue
            text = said[sender]
            size = len(text.encode("utf-8"))
            d = np.hypot(*(xy - xy[index[sender]]).T)
            for i in np.flatnonzero(d < self.cfg.range_m):
                rid = msg.ids[int(i)]
                if budget[rid] < size:
                    dropped["over_budget"] = dropped.get("over_budget", 0) + 1
                    continue
                budget[rid] -= size
                hear.setdefault(rid, []).append(Heard(sender=sender, distance_m=float(d[i]), text=text))
        out: list[Outgoing] = []
        batch = [
            Hear(tick=msg.tick, sim_time_ns=msg.sim_time_ns, robot_id=rid, messages=m)
            for rid, m in sorted(hear.items())
        ]
        out += [(keys.hear(self.sim, h.robot_id), h) for h in batch]
        out.append((keys.radio(self.sim), RadioBatch(tick=msg.tick, sim_time_ns=msg.sim_time_ns, hear=batch)))
        if dropped:
            total = sum(dropped.values())
            ev = make_event(
                EventKind.RADIO_DROPPED,
                RadioDroppedData(**dropped),
                reason=f"{total} radio messages dropped",
                tick=msg.tick,
                sim_time_ns=msg.sim_time_ns,
                source="radio",
            )
            out.append((keys.event(self.sim, EventKind.RADIO_DROPPED), ev))
        return out


def run(bus: Bus, sim: str, cfg: RadioConfig | None = None, *, name: str = "radio", io: NodeIO | None = None) -> None:
    """Delivers radio messages every tick until stopped."""
    io = io or NodeIO(bus, sim, "radio", name)
    says = io.inbox(keys.all_say(sim))
    states = io.inbox(keys.state(sim))
    node = RadioNode(sim, cfg)
    io.alive()
    while not io.stop.is_set():
        got = False
        for d in says.drain():
            got = True
            msg = io.decode(d, Say)
            if msg is not None and keys.robot_id_of(d[0]) == msg.robot_id:
                node.on_say(msg)
        for d in states.drain():
            got = True
            st = io.decode(d, WorldState)
            if st is not None:
                io.send_all(node.on_state(st))
        if not got:
            io.wait(0.2)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz radio``."""
    return start_role(
        argv,
        role="radio",
        description="Robot-to-robot messages, delivered only to robots within range.",
        epilog="Example (a shorter range than Ciber-Rato's 8 m):\n  iwz radio --range 4",
        arguments=_arguments,
        prepare=_config,
        run=lambda proc, cfg: run(proc.bus, proc.sim, cfg, io=proc.io),
    )


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--range", type=float, default=8.0, help="delivery range in metres (default 8)")
    p.add_argument(
        "--max-bytes", type=int, default=100, help="longest message in bytes; longer ones are dropped (default 100)"
    )
    p.add_argument("--budget", type=int, default=400, help="bytes a robot hears per tick at most (default 400)")


def _config(args: argparse.Namespace) -> RadioConfig:
    if args.range <= 0 or args.max_bytes <= 0 or args.budget <= 0:
        raise ValueError("--range, --max-bytes and --budget must be > 0")
    return RadioConfig(args.range, args.max_bytes, args.budget)
