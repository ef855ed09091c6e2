"""A registration answered: a robot placed, or one whose agent restarted reclaimed, or a refusal
with its reason (a spec out of range, no room, a secured run's robot not the agent's own).

:meth:`WorldCore.register` keeps each request's first answer for a request asked again and
calls :func:`admit` for a new one.
"""

from __future__ import annotations

import itertools
from dataclasses import replace
from typing import TYPE_CHECKING

from iw_zenoh import keys
from iw_zenoh.convert import spec_from_msg, spec_to_msg
from iw_zenoh.core.modes import Profile
from iw_zenoh.errors import SpecError
from iw_zenoh.messages import EventKind, Outgoing, RefusedData, RegisteredData, RegisterReply, RegisterRequest
from iw_zenoh.sim import registry as roster
from iw_zenoh.sim.registry import Refused, Registry

if TYPE_CHECKING:
    from iw_zenoh.core.spec import RobotSpec
    from iw_zenoh.sim.world import WorldCore

__all__ = ["admit", "owned_id"]


def admit(core: WorldCore, req: RegisterRequest, now_ns: int) -> tuple[RegisterReply, list[Outgoing]]:
    """Accepts or refuses one registration request in ``core``'s world.

    Args:
        core: The world (its roster, state and presence change when the robot is accepted).
        req: The request.
        now_ns: Now, on the world's clock.

    Returns:
        The answer to the asker, and what to publish (the spec and a registered event, or a
        refused event).
    """
    try:
        spec = spec_from_msg(req.spec)
    except SpecError as e:
        return _refuse(core, req, f"field {e.field}: {e.reason}")
    instance = req.request_id.partition("-")[0]
    registry = core.registry
    again = registry.reclaimable(spec, req.agent, instance)
    if again is not None:  # its agent restarted: the same robot, answered with where it is now
        entry, placed = registry.reclaim(again, core.state, now_ns)
    else:
        placed_or_why = _place_new(core, req, spec)
        if isinstance(placed_or_why, str):
            return _refuse(core, req, placed_or_why)
        placed = placed_or_why
        entry = registry.add(placed, req.agent, now_ns)
        core.roster_changed()
    entry.instance = instance
    # lock-step: its first readings are of the next tick, so it owes nothing for this one;
    # and its agent is alive
    entry.last_action_tick = core.tick
    if req.agent:
        core.presence.agent_registered(req.agent, now_ns)
    msg = spec_to_msg(placed)
    reply = RegisterReply(tick=core.tick, sim_time_ns=core.sim_time_ns(), ok=True, robot_id=placed.id, spec=msg)
    out: list[Outgoing] = [
        (keys.spec(core.cfg.sim, placed.id), reply),
        core.event(
            EventKind.REGISTERED,
            f"robot {placed.id} {placed.name!r} at ({placed.x_m:g}, {placed.y_m:g})",
            placed.id,
            payload=RegisteredData(agent=req.agent),
        ),
    ]
    return reply, out


def _place_new(core: WorldCore, req: RegisterRequest, spec: RobotSpec) -> RobotSpec | str:
    """A new robot's id and start pose, or why it is refused: the agent's bound, the ids it may
    ask for (its owners' and the scenario's reserved ids), a free place (on other robots too in
    the ciberrato profile, as the legacy simulator's starts)."""
    registry = core.registry
    if req.agent and registry.per_agent[req.agent] >= roster.MAX_ROBOTS_PER_AGENT:
        return f"agent {req.agent!r} has {roster.MAX_ROBOTS_PER_AGENT} robots, the most one agent may register"
    owned = owned_id(core.cfg.owners, registry, req.agent, spec.id)
    if isinstance(owned, str):
        return owned
    reserved = core.cfg.reserved or {}
    mine = set(reserved.get(req.agent, ()))  # shared too (the chair's bridge and its agent)
    theirs = {r: a for a, rs in reserved.items() if a != req.agent for r in rs if r not in mine}
    if owned in theirs:
        return f"robot {owned} is the scenario's, for agent {theirs[owned]!r}; ask for another id, or 0 for a free one"
    legacy = Profile(core.cfg.profile) == Profile.CIBERRATO
    try:
        return registry.place(replace(spec, id=owned), registry.poses(core.state), skip=set(theirs), on_robots=legacy)
    except Refused as e:
        return str(e)


def owned_id(
    owners: dict[str, tuple[int, ...] | None] | None, registry: Registry, agent: str, robot_id: int
) -> int | str:
    """The id a secured run lets ``agent`` register, or why not.

    Args:
        owners: The run's policy: each agent's robots (``None``: any); ``None``: an open run.
        registry: The roster (for id 0, the first of the agent's robots not taken).
        agent: Who asks.
        robot_id: The id asked (0: any).

    Returns:
        The id (in an open run, ``robot_id`` as asked), or the reason it is refused.
    """
    if owners is None:
        return robot_id
    if agent not in owners:
        return f"agent {agent!r} may register no robot: the policy does not name it an agent"
    mine = owners[agent]
    if mine is None:
        return _unreserved(owners, registry, agent, robot_id)
    if robot_id and robot_id not in mine:
        return f"robot {robot_id} is not agent {agent!r}'s: the policy gives it {list(mine)}"
    if robot_id:
        return robot_id
    free = [r for r in mine if r not in registry.entries]
    return free[0] if free else f"agent {agent!r} has every robot the policy gives it ({list(mine)}) already"


def _refuse(core: WorldCore, req: RegisterRequest, reason: str) -> tuple[RegisterReply, list[Outgoing]]:
    reply = RegisterReply(tick=core.tick, sim_time_ns=core.sim_time_ns(), ok=False, reason=reason)
    return reply, [
        core.event(EventKind.REFUSED, reason, req.spec.id, payload=RefusedData(name=req.spec.name, agent=req.agent))
    ]


def _unreserved(owners: dict[str, tuple[int, ...] | None], registry: Registry, agent: str, robot_id: int) -> int | str:
    """For an agent the policy lets register any robot (a legacy bridge registering for its UDP
    clients): ``robot_id`` unless the policy gives it to another agent; for 0, the first id neither
    taken nor another agent's (so a legacy client cannot take, or block, an agent's own robot)."""
    theirs = {r: a for a, rs in owners.items() if a != agent and rs for r in rs}
    if robot_id in theirs:
        return (
            f"robot {robot_id} is agent {theirs[robot_id]!r}'s by the policy; ask for another id, or 0 for a free one"
        )
    if robot_id or not theirs:
        return robot_id
    return next(k for k in itertools.count(1) if k not in registry.entries and k not in theirs)
