"""The world's batched messages of a tick, built from its arrays: the proposal the collision
check judges, the committed state everyone reads, and what each new collision hit."""

from __future__ import annotations

import numpy as np

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.motor import MAX_POWER
from iw_zenoh.core.world import Proposal, WorldState
from iw_zenoh.messages import CollisionData, Hit, Proposed, Verdict
from iw_zenoh.messages import WorldState as WorldStateMsg

__all__ = ["collision_reports", "proposed_msg", "speeds", "state_msg"]


def proposed_msg(
    state: WorldState, prop: Proposal, ids: list[int], *, sim_time_ns: int, revision: int, wall_ns: int
) -> Proposed:
    """Tick n's proposal: every robot's pose now and its next pose, in array order.

    Args:
        state: The state of tick n - 1 (its commands applied).
        prop: The next poses, speeds and distances rolled.
        ids: Robot ids in array order.
        sim_time_ns: Simulated time of tick n.
        revision: The roster's revision.
        wall_ns: Wall-clock time the tick began (0: unknown), for latency logs.

    Returns:
        The message, tick ``state.tick + 1``.
    """
    # one tolist() per array (its columns as lists), not one per column
    x, y, heading = state.pose.T.tolist()
    next_x, next_y, next_heading = prop.pose.T.tolist()
    rolled_left, rolled_right = prop.rolled_m.T.tolist()
    return Proposed(
        tick=state.tick + 1,
        sim_time_ns=sim_time_ns,
        revision=revision,
        ids=list(ids),
        x=x,
        y=y,
        heading=heading,
        next_x=next_x,
        next_y=next_y,
        next_heading=next_heading,
        linear=prop.linear.tolist(),
        active=[True] * len(ids),
        rolled_left=rolled_left,
        rolled_right=rolled_right,
        tick_wall_ns=wall_ns,
    )


def state_msg(
    s: WorldState,
    ids: list[int],
    *,
    sim_time_ns: int,
    revision: int,
    speed_mps: np.ndarray,
    held_reason: str | None,
    tick_wall_ns: int,
) -> WorldStateMsg:
    """A committed tick's state.

    Args:
        s: The committed state.
        ids: Robot ids in array order.
        sim_time_ns: Simulated time of the tick.
        revision: The roster's revision.
        speed_mps: (N,) each robot's speed over the tick had it moved (see :func:`speeds`).
        held_reason: None when robots moved; when every robot was held still, why (may be "").
        tick_wall_ns: Wall-clock time the tick began (0: unknown).

    Returns:
        The message; a robot that collided or was held has speed 0.
    """
    moved = ~s.collided if held_reason is None else np.zeros(len(ids), dtype=bool)
    speed = np.where(moved, speed_mps, 0.0)
    x, y, heading = s.pose.T.tolist()
    rolled_left, rolled_right = s.rolled_m.T.tolist()
    return WorldStateMsg(
        tick=s.tick,
        sim_time_ns=sim_time_ns,
        revision=revision,
        ids=ids,
        x=x,
        y=y,
        heading=heading,
        collided=s.collided.tolist(),
        rolled_left=rolled_left,
        rolled_right=rolled_right,
        speed=np.asarray(speed, dtype=float).tolist(),
        held=held_reason is not None,
        held_reason=held_reason or "",
        tick_wall_ns=tick_wall_ns,
    )


def speeds(prop: Proposal, *, profile: Profile, bodies: Bodies, period_ms: float) -> np.ndarray:
    """(N,) each robot's speed over a tick, m/s, from its proposal: the linear term is a power
    in the native profile and metres per tick in Ciber-Rato's."""
    if profile == Profile.NATIVE:
        return np.asarray(prop.linear / MAX_POWER * bodies.drive.max_speed_mps, dtype=float)
    return np.asarray(prop.linear / (period_ms / 1000.0), dtype=float)


def collision_reports(
    verdict: Verdict, ids: list[int], new: np.ndarray, pose: np.ndarray
) -> list[tuple[int, str, CollisionData]]:
    """What each robot that began a collision this tick hit, for its ``collision`` event.

    Args:
        verdict: The tick's verdict.
        ids: Robot ids in array order.
        new: (N,) bool, robots in collision now and not before.
        pose: (N, 3) committed poses.

    Returns:
        ``(robot id, reason, payload)`` per new collision, in array order.
    """
    by_robot: dict[int, list[Hit]] = {}
    for h in verdict.hits:
        by_robot.setdefault(h.robot_id, []).append(h)
    out: list[tuple[int, str, CollisionData]] = []
    for i in np.flatnonzero(new).tolist():
        rid = ids[i]
        hits = by_robot.get(rid, [])
        what = ", ".join(f"wall {h.wall}" if h.wall >= 0 else f"robot {h.other}" for h in hits)
        x, y = pose[i, :2]
        walls = [h.wall for h in hits if h.wall >= 0]
        robots = [h.other for h in hits if h.other >= 0]
        reason = f"robot {rid} hit {what or 'something'} at ({x:.2f}, {y:.2f})"
        out.append((rid, reason, CollisionData(x=float(x), y=float(y), walls=walls, robots=robots)))
    return out
