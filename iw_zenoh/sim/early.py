"""When a tick's outcome is known before the world commits it: the collision verdict confirms the
proposal, so the sensors and the radio may publish tick n from the proposal at once.

The world commits (:func:`iw_zenoh.core.world.commit`) the proposal's next poses and distances
rolled, with every collision flag cleared, whenever it takes a verdict on that proposal that
flags no robot: a flag from an earlier tick does not stay set (it is the verdict's flag, and no
held robot's), a Real robot's reported pose is already the proposal's, and the world takes no
input between proposing and committing (no robot registers, leaves or is removed, no obstacle
moves: the revision and the roster are the proposal's). What remains is the verdict the world did
not take (it came after the world's deadline, or the world saw no collision process alive): the
world then holds every robot, and a receiver that published early learns it from the state.
"""

from __future__ import annotations

from collections.abc import Iterable

from iw_zenoh.errors import IwError
from iw_zenoh.messages import Proposed, Verdict, WorldState, decode

__all__ = ["Verdicts", "confirms", "state_from_proposal"]


def state_from_proposal(p: Proposed) -> WorldState:
    """The state tick n will commit if no robot collides and none is held."""
    n = len(p.ids)
    return WorldState(
        tick=p.tick,
        sim_time_ns=p.sim_time_ns,
        revision=p.revision,
        ids=list(p.ids),
        x=list(p.next_x),
        y=list(p.next_y),
        heading=list(p.next_heading),
        collided=[False] * n,
        rolled_left=list(p.rolled_left),
        rolled_right=list(p.rolled_right),
        speed=[0.0] * n,  # not read by sensors
        tick_wall_ns=p.tick_wall_ns,
    )


def confirms(p: Proposed | WorldState, v: Verdict) -> bool:
    """Whether verdict ``v`` confirms proposal ``p`` (or the state made from it): it answers that
    very proposal, as the world checks one (its tick, revision and robots), and flags no robot, so
    the world, if it takes it, commits :func:`state_from_proposal` of it."""
    return v.tick == p.tick and v.revision == p.revision and v.ids == p.ids and not any(v.collided)


class Verdicts:
    """The newest verdicts heard, by tick: a verdict may come before the proposal it answers (each
    subscription is delivered on its own), so it waits here until that proposal is computed.

    Args:
        kept: Verdicts kept (one comes a tick).
    """

    def __init__(self, kept: int = 4) -> None:
        self.kept = kept
        self._by_tick: dict[int, Verdict] = {}

    def take(self, payloads: Iterable[bytes]) -> None:
        """Keeps the verdicts of ``payloads`` (one that does not decode is skipped: the world, which
        acts on verdicts, reports it)."""
        for data in payloads:
            try:
                v = decode(data, Verdict)
            except IwError:
                continue
            self._by_tick[v.tick] = v
        if len(self._by_tick) > self.kept:
            for t in sorted(self._by_tick)[: -self.kept]:
                del self._by_tick[t]

    def confirm(self, p: Proposed | WorldState) -> bool:
        """Whether a verdict heard confirms ``p`` (:func:`confirms`)."""
        v = self._by_tick.get(p.tick)
        return v is not None and confirms(p, v)
