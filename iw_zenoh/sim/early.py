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

from collections.abc import Callable, Iterable

from iw_zenoh.errors import IwError
from iw_zenoh.messages import Proposed, Verdict, WorldState, decode

__all__ = ["VERDICTS_A_TICK", "Verdicts", "confirms", "state_from_proposal"]


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


VERDICTS_A_TICK = 4  # one comes from the collision process; more are forged, or a second collision process's


class Verdicts:
    """The verdicts heard for the next ticks: a verdict may come before the proposal it answers
    (each subscription is delivered on its own), so it waits here until that proposal is computed.

    A tick's verdicts are kept in the order they came, and the first that answers the proposal
    (its tick, revision and robots) is the one that counts, as the world takes the first. What is
    refused is said by :meth:`refusals`: a verdict that does not decode, one of a tick too far
    ahead, one past :data:`VERDICTS_A_TICK` for its tick, one that answers another revision or
    other robots than the state of its tick (:meth:`settle`). A verdict of a tick more than
    ``kept`` ahead of the last state settled is dropped unrefused (a receiver that fell behind
    hears those too; it can use none of them now).

    Args:
        kept: Ticks whose verdicts are kept (one comes a tick).
        per_tick: Verdicts kept for one tick.
    """

    def __init__(self, kept: int = 4, per_tick: int = VERDICTS_A_TICK) -> None:
        self.kept = kept
        self.per_tick = per_tick
        self._by_tick: dict[int, list[Verdict]] = {}
        self._settled: int | None = None  # the newest tick whose state came
        self._refused: list[str] = []

    def take(self, payloads: Iterable[bytes], ahead: Callable[[int], str] = lambda tick: "") -> None:
        """Keeps the verdicts of ``payloads``; the ones refused are told by :meth:`refusals`.

        Args:
            payloads: Verdicts as received.
            ahead: Why a tick is too far ahead of the world as the receiver knows it, or ``""``
                (:meth:`iw_zenoh.ticks.TickWindow.ahead`).
        """
        for data in payloads:
            try:
                v = decode(data, Verdict)
            except IwError as e:
                self._refused.append(str(e))
                continue
            why = ahead(v.tick)
            if why:
                self._refused.append(f"verdict: {why}")
            elif self._settled is None or self._settled < v.tick <= self._settled + self.kept:
                held = self._by_tick.setdefault(v.tick, [])
                if len(held) < self.per_tick:
                    held.append(v)
                else:
                    self._refused.append(f"a verdict of tick {v.tick} past the {self.per_tick} kept for a tick")
        if len(self._by_tick) > self.kept:
            for t in sorted(self._by_tick)[: -self.kept]:
                del self._by_tick[t]

    def confirm(self, p: Proposed | WorldState) -> bool:
        """Whether the first verdict heard that answers ``p`` confirms it (:func:`confirms`)."""
        for v in self._by_tick.get(p.tick, ()):
            if v.revision == p.revision and v.ids == p.ids:
                return not any(v.collided)
        return False

    def settle(self, st: WorldState) -> None:
        """The state of a tick came: its verdicts that answer another revision or other robots are
        refused, and every verdict of it and before is forgotten (none can be used any more)."""
        for v in self._by_tick.get(st.tick, ()):
            if v.revision != st.revision or v.ids != st.ids:
                self._refused.append(
                    f"a verdict of tick {v.tick} answers revision {v.revision} and robots {v.ids[:5]} "
                    f"({len(v.ids)}), not the world's: revision {st.revision}, robots {st.ids[:5]} ({len(st.ids)})"
                )
        for t in [t for t in self._by_tick if t <= st.tick]:
            del self._by_tick[t]
        self._settled = st.tick

    def refusals(self) -> list[str]:
        """Why each verdict refused since the last call was refused (then forgotten)."""
        out, self._refused = self._refused, []
        return out
