"""The radio's logic: robot-to-robot messages, delivered only within range.

Defaults follow Ciber-Rato DCOSS: 8 m range, at most 100 bytes a message, at most 400 bytes
heard per robot per tick (in a ciberrato-profile world, :attr:`RadioNode.legacy`, the legacy
simulator's rules instead: at most 100 *characters* a message, no budget per tick); a message
said during tick n is heard in tick n+1 by every robot
(the speaker included) whose centre is closer than the range, in sender order. What is dropped
(too long, over a robot's budget, from an unknown robot) is counted in a ``radio-dropped`` event.

Tick n is delivered as soon as the collision verdict confirms the world's proposal (the positions
it proposed are those it commits: :mod:`iw_zenoh.sim.early`); the state then only checks them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from iw_zenoh import keys
from iw_zenoh.messages import (
    Event,
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

__all__ = ["RadioConfig", "RadioNode"]


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
        self._early: tuple[WorldState, dict[int, str]] | None = None  # delivered early: where, what
        self.corrections = 0  # ticks delivered early whose state proved the positions wrong
        self.legacy = False  # the world's profile is ciberrato: characters, not bytes; no budget

    def on_say(self, msg: Say) -> None:
        """Keeps a robot's latest message of this tick (one per robot, the last wins)."""
        size = len(msg.text) if self.legacy else len(msg.text.encode("utf-8"))
        if size > self.cfg.max_message_bytes:
            self._dropped["too_long"] = self._dropped.get("too_long", 0) + 1
            return
        self._said[msg.robot_id] = msg.text

    def on_state(self, msg: WorldState) -> list[Outgoing]:
        """Delivers what was said since the last state."""
        said, self._said = self._said, {}
        dropped, self._dropped = self._dropped, {}
        return self._deliver(msg, said, dropped)

    def send_early(self, msg: WorldState) -> list[Outgoing]:
        """Delivers what was said since the last state, in the state the world will commit
        (:func:`iw_zenoh.sim.early.state_from_proposal`, when the verdict confirms the proposal),
        before it commits; what was said is kept until the state says the positions were right."""
        self._early = (msg, self._said)
        return self.on_state(msg)

    def check_early(self, msg: WorldState) -> list[Outgoing]:
        """The committed state of the tick delivered early: nothing when the robots are where they
        were delivered at (the usual case); otherwise (the world held the tick) the same messages
        delivered again at the committed positions (their drops already counted)."""
        sent, said = self._early or (None, {})
        self._early = None
        if sent is None or (sent.tick, sent.ids, sent.x, sent.y) == (msg.tick, msg.ids, msg.x, msg.y):
            return []
        self.corrections += 1
        return [(k, m) for k, m in self._deliver(msg, said, {}) if not isinstance(m, Event)]

    def forget_early(self) -> None:
        """Forgets the tick delivered early without checking it: its state will not come (a newer
        state came instead, e.g. a restarted world's)."""
        self._early = None

    @property
    def early_tick(self) -> int | None:
        """The tick delivered early whose state has not come yet, or None."""
        return None if self._early is None else self._early[0].tick

    def _deliver(self, msg: WorldState, said: dict[int, str], dropped: dict[str, int]) -> list[Outgoing]:
        """What each robot hears of ``said`` at the positions of ``msg``, and what was dropped."""
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
                if budget[rid] < size and not self.legacy:
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
