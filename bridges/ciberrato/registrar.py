"""Who may join through the legacy bridge: the legacy registrations waiting for the world's answer
(asked again while no world answers), at most MAX_PENDING at once.

No sockets here: the node hands in parsed registrations and sends what the registrar decides.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Collection
from dataclasses import dataclass

from iw_zenoh.agent.hosting import WorldRegistration
from iw_zenoh.bus import Bus
from iw_zenoh.convert import spec_to_msg
from iw_zenoh.core.params import SimParameters
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.errors import IwError
from iw_zenoh.messages import RegisterReply, RegisterRequest, WorldInfo

from .registration import Registration, registration_spec

__all__ = [
    "MAX_PENDING",
    "WORLD_WAIT_S",
    "Admission",
    "Pending",
    "Registrar",
]

MAX_PENDING = 64  # registrations waiting for the world's answer at once; more are refused
WORLD_WAIT_S = 10.0  # a registration no world answers is asked again this long (a world still starting)
QUERY_TIMEOUT_S = 2.0  # one ask of the world's registration queryable waits this long

Peer = tuple[str, int]

logger = logging.getLogger(__name__)


@dataclass
class Pending:
    """A legacy registration waiting for the world's answer."""

    asked: WorldRegistration
    spec: RobotSpec
    carried: int  # beacons robots carried when it asked (the lab's own are counted at the answer)


@dataclass(frozen=True)
class Admission:
    """What to do with a registration datagram.

    Attributes:
        refused: The reason it is refused, or "" when it is not.
        answer: Whether a refused registration is answered with a refusal (the legacy server
            answers nothing to what does not parse).
        viewer: ``view`` or ``panel`` for a viewer to serve at once; "" otherwise.
        params: The parameters a viewer is told.
        nb: NBeacons in a viewer's reply.
    """

    refused: str = ""
    answer: bool = True
    viewer: str = ""
    params: SimParameters | None = None
    nb: int = 0


class Registrar:
    """The legacy registrations: refused by the legacy rules, or asked of the world.

    Args:
        bus: The bus (registrations are asked on it).
        sim: Simulation name.
        agent: The bridge's agent name (its robots are its own).
        params: The legacy parameters clients are told.
    """

    def __init__(self, bus: Bus, sim: str, agent: str, params: SimParameters) -> None:
        self.bus = bus
        self.sim = sim
        self.agent = agent
        self.params = params
        self.pending: dict[Peer, Pending] = {}
        self.carriers: set[int] = set()  # legacy robots accepted here that carry a beacon

    def told(self, info: WorldInfo | None) -> tuple[SimParameters, int]:
        """The parameters and NBeacons a client is told in a world described by ``info``."""
        if info is None:
            return self.params, 0
        params = SimParameters(**{**self.params.__dict__, "cycle_time_ms": max(1, info.period_ns // 1_000_000)})
        return params, len(info.lab.beacons)

    def admit(
        self, reg: Registration, peer: Peer, info: WorldInfo | None, registered: Collection[int], now: float
    ) -> Admission:
        """Decides on a registration: a viewer to serve, a refusal, or asked of the world.

        Args:
            reg: The parsed registration.
            peer: Its sender.
            info: The world's description, if known.
            registered: Ids of the legacy robots accepted here and still served.
            now: Monotonic seconds.
        """
        params, nb = self.told(info)
        if reg.kind in ("view", "panel"):
            return Admission(viewer=reg.kind, params=params, nb=nb)
        self.carriers &= set(registered)  # those let go since carry nothing here any more
        try:
            spec = registration_spec(reg, self.params)
        except IwError as e:
            return Admission(refused=str(e))
        if peer in self.pending:
            return Admission()  # asked already; the answer is on its way (a client repeating itself)
        if len(self.pending) >= MAX_PENDING:
            return Admission(refused=f"{MAX_PENDING} registrations are waiting for the world's answer already")
        # beacons robots carry: those the world's description lists, and those accepted or being
        # registered here since (the description is published a moment later)
        carried = {r.id for r in info.robots if r.beacon_height_m is not None} if info else set()
        carried |= self.carriers
        n_carried = len(carried) + sum(1 for p in self.pending.values() if p.spec.beacon_height_m is not None)
        if reg.kind == "beacon" and (nb or n_carried):
            # the legacy rule: one beacon at most, and a RobotBeacon becomes the lab's beacon
            return Admission(refused="a RobotBeacon is refused when the lab already has a beacon")
        # beacon sensors are made for the beacons there are now (later RobotBeacons: none)
        req = RegisterRequest(
            spec=spec_to_msg(spec),
            agent=self.agent,
            request_id=f"{os.getpid()}-{peer[0]}-{peer[1]}-{time.monotonic_ns()}",
        )
        # the world's answer is awaited by the node's loop, not here: the other clients go on
        asked = WorldRegistration(
            self.bus, self.sim, req, now=now, patience_s=WORLD_WAIT_S, query_timeout_s=QUERY_TIMEOUT_S
        )
        self.pending[peer] = Pending(asked, spec, n_carried)
        return Admission()

    def answered(self, now: float) -> list[tuple[Peer, Pending, RegisterReply | None]]:
        """The registrations now over, each with the world's answer (None: no world answered in
        WORLD_WAIT_S, or its answer did not decode).

        Args:
            now: Monotonic seconds.
        """
        done: list[tuple[Peer, Pending, RegisterReply | None]] = []
        for peer, p in list(self.pending.items()):
            if not p.asked.poll(now):
                continue
            del self.pending[peer]
            try:
                reply = p.asked.reply()
            except IwError as e:
                logger.warning("the world's registration answer does not decode: %s", e)
                reply = None
            done.append((peer, p, reply))
        return done

    def accepted(self, robot_id: int, spec: RobotSpec) -> None:
        """Notes a robot the world accepted (a beacon it carries counts from now)."""
        if spec.beacon_height_m is not None:
            self.carriers.add(robot_id)
