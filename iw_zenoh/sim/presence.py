"""Who the world depends on: the collision and sensors processes and the agents alive; in
lock-step, which robots a tick still waits for; and why every robot is held still, if it is."""

from __future__ import annotations

from typing import Protocol

from iw_zenoh.messages import AgentLostData, EventData, EventKind, Outgoing
from iw_zenoh.sim.registry import Registry

__all__ = ["EventMaker", "Presence"]


class EventMaker(Protocol):
    """Makes one of the world's events, stamped with the current tick."""

    def __call__(
        self, kind: EventKind, reason: str, robot_id: int = -1, key: str = "", payload: EventData | None = None
    ) -> Outgoing:
        """The event's key and message."""
        ...


class Presence:
    """The processes the world waits for, by liveliness name.

    Args:
        registry: The roster (each robot names its agent).
        lockstep: Whether the world runs in lock-step (it then waits for lost processes).
        event: Makes the world's events.
    """

    def __init__(self, registry: Registry, *, lockstep: bool, event: EventMaker) -> None:
        self.registry = registry
        self.lockstep = lockstep
        self._event = event
        self.collision: set[str] = set()
        self.sensors: set[str] = set()
        self.agents: set[str] = set()
        self.seen: set[str] = set()  # agents whose liveliness token is there
        # agents that registered while their token was not there, by when (oldest first): one
        # whose token never comes is lost after the grace period (:meth:`overdue`), or a flood
        # of registrations for agents that do not exist left robots no one drives, for ever
        self.unconfirmed: dict[str, int] = {}
        self.holding = ""  # why every robot is held still ("" when they move)
        # lock-step: the robots tick n still waits for, kept up to date as actions arrive (the
        # loop asks after every input; scanning the roster each time is quadratic at 1,000 robots)
        self._awaiting: tuple[int, set[int]] | None = None

    def on_alive(self, role: str, name: str, alive: bool, now_ns: int) -> list[Outgoing]:
        """Tracks collision and sensors processes and agents; an agent lost zeroes its robots at once."""
        self._awaiting = None
        out: list[Outgoing] = []
        if role == "collision":
            was = bool(self.collision)
            (self.collision.add if alive else self.collision.discard)(name)
            if was and not self.collision and self.lockstep:
                self.holding = "no collision process is alive: lock-step waits until one is back"
                out.append(self._event(EventKind.HOLDING, f"every robot held still: {self.holding}"))
        elif role == "sensors":
            was = bool(self.sensors)
            (self.sensors.add if alive else self.sensors.discard)(name)
            if was and not self.sensors and self.lockstep:
                out.append(
                    self._event(
                        EventKind.SENSORS_LOST, "no sensors process is alive: lock-step waits until one is back"
                    )
                )
        elif role == "agent":
            self.unconfirmed.pop(name, None)
            if alive:
                self.agents.add(name)
                self.seen.add(name)
                self.registry.agent_back(name)
            else:
                self.agents.discard(name)
                self.seen.discard(name)
                out += [
                    self._event(
                        EventKind.AGENT_LOST,
                        f"agent {name!r} is gone: robot {rid} stopped",
                        rid,
                        payload=AgentLostData(agent=name),
                    )
                    for rid in self.registry.agent_lost(name, now_ns)
                ]
        return out

    def on_verdict(self, got: bool, robots: bool) -> list[Outgoing]:
        """Without a verdict every robot is held still (said once per reason); with one after a
        hold, robots move again.

        Args:
            got: Whether the tick has its verdict.
            robots: Whether there is any robot (an empty world holds nobody: a world starting first).
        """
        if not got:
            reason = "no collision process is alive" if not self.collision else "the collision verdict is late"
            if robots and self.holding != reason:
                self.holding = reason
                return [self._event(EventKind.HOLDING, f"every robot held still: {reason}")]
            return []
        out = [self._event(EventKind.RESUMED, "collision verdicts are back; robots move again")] if self.holding else []
        self.holding = ""
        return out

    def complete(self, *, first: bool = False) -> bool:
        """Whether a tick may step as far as processes go: in lock-step, a robot needs a collision
        and a sensors process alive (a tick stepped without verdicts would hold every robot, and
        one without readings could not be answered; either would make a run depend on when those
        processes joined); so does the ``first`` step of a legacy run in real time (the legacy
        simulator never holds a robot at its start)."""
        needed = self.lockstep or first
        return not (needed and self.registry.entries and not (self.sensors and self.collision))

    def agent_registered(self, agent: str, now_ns: int) -> None:
        """An agent registered a robot: it is alive (it declares its token before it registers),
        whether or not the token has reached us yet; waiting for it from the first tick keeps a
        run the same every time. Until its token is seen it is on probation (:meth:`overdue`)."""
        self.agents.add(agent)
        if agent not in self.seen:
            self.unconfirmed.setdefault(agent, now_ns)
        self._awaiting = None

    def overdue(self, now_ns: int, grace_ns: int) -> list[Outgoing]:
        """Agents that registered more than ``grace_ns`` ago and whose token never came are lost,
        as if it had gone when they registered: their robots stop and are removed at the next
        tick (a registration flood for agents that do not exist leaves no robot behind; lock-step
        stops waiting for them)."""
        out: list[Outgoing] = []
        while self.unconfirmed:
            agent, since = next(iter(self.unconfirmed.items()))
            if now_ns - since <= grace_ns:
                break
            del self.unconfirmed[agent]
            self.agents.discard(agent)
            self._awaiting = None
            out += [
                self._event(
                    EventKind.AGENT_LOST,
                    f"agent {agent!r} registered robot {rid} but its liveliness never appeared: robot {rid} stopped",
                    rid,
                    payload=AgentLostData(agent=agent),
                )
                for rid in self.registry.agent_lost(agent, since)
            ]
        return out

    def forget(self) -> None:
        """The roster changed: which robots a tick waits for is worked out again."""
        self._awaiting = None

    def expected(self, tick: int) -> list[int]:
        """Robots whose actions for sensors tick ``tick`` lock-step still waits for."""
        return [
            rid
            for rid, e in self.registry.entries.items()
            if e.agent and e.agent in self.agents and e.lost_ns is None and e.last_action_tick < tick
        ]

    def waiting(self, tick: int) -> bool:
        """Whether lock-step still waits for some robot's actions for sensors tick ``tick``."""
        return self.waiting_for(tick) > 0

    def waiting_for(self, tick: int) -> int:
        """How many robots' actions for sensors tick ``tick`` lock-step still waits for (those of
        :meth:`expected`, without listing them every time)."""
        if self._awaiting is None or self._awaiting[0] != tick:
            self._awaiting = (tick, set(self.expected(tick)))
        return len(self._awaiting[1])

    def answered(self, robot_id: int, tick: int) -> None:
        """A robot answered sensors tick ``tick``."""
        if self._awaiting is not None and tick >= self._awaiting[0]:
            self._awaiting[1].discard(robot_id)
