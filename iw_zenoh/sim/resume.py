"""A world's last committed state, as ``iwz run`` hands it to the world it restarts.

The launcher already hears every committed state, the world's description and the
``registered`` / ``removed`` events; from them it keeps a :class:`WorldSnapshot`
(:func:`snapshot`), and a world started with one (``WorldOptions.resume``) goes on from there
(:func:`resume`): the same tick and simulated time, every robot with its id, spec, agent, pose,
wheel speeds and collision flag, the obstacles of the moment. The world itself never writes a file.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Annotated

import msgspec
import numpy as np

from iw_zenoh.convert import spec_from_msg
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.motor import MAX_POWER
from iw_zenoh.messages import Obstacle, RobotSpecMsg, WorldInfo, WorldState

if TYPE_CHECKING:
    from iw_zenoh.sim.world import WorldCore

__all__ = ["SnapshotRobot", "WorldSnapshot", "resume", "snapshot"]


class SnapshotRobot(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One robot of a snapshot.

    Attributes:
        spec: Its accepted spec (id set; x, y, dir are where it started).
        agent: Liveliness name of the agent process driving it ("" for none).
        pose: Where it is now: x (m), y (m), heading (rad); None: at its start pose (registered
            after the last state the launcher heard).
        rolled: How far each wheel rolled in the last tick (m), its motors' speed.
        collided: Whether it was in collision.
    """

    spec: RobotSpecMsg
    agent: str = ""
    pose: tuple[float, float, float] | None = None
    rolled: tuple[float, float] = (0.0, 0.0)
    collided: bool = False


class WorldSnapshot(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A world's last committed state.

    Attributes:
        tick: The last committed tick (the resumed world steps ``tick + 1`` next).
        revision: The last revision of the world's description (the resumed one's is newer, so
            every node asks for it again).
        running: False when the world was paused.
        robots: Every registered robot, in the order of the world's arrays.
        obstacles: The obstacles of the moment.
    """

    tick: Annotated[int, msgspec.Meta(ge=0)] = 0
    revision: Annotated[int, msgspec.Meta(ge=0)] = 0
    running: bool = True
    robots: tuple[SnapshotRobot, ...] = ()
    obstacles: tuple[Obstacle, ...] = ()


def snapshot(state: WorldState | None, info: WorldInfo, owners: dict[int, str], *, running: bool) -> WorldSnapshot:
    """A snapshot from the last committed state and description heard, and each robot's agent.

    Args:
        state: The last committed state (None: the world never stepped).
        info: The world's latest description (its robots are the roster).
        owners: The agent of each robot, from the ``registered`` events.
        running: Whether the world was running (not paused).
    """
    where: dict[int, int] = {rid: i for i, rid in enumerate(state.ids)} if state is not None else {}
    robots: list[SnapshotRobot] = []
    for spec in info.robots:
        i = where.get(spec.id)
        if state is None or i is None:
            robots.append(SnapshotRobot(spec=spec, agent=owners.get(spec.id, "")))
            continue
        robots.append(
            SnapshotRobot(
                spec=spec,
                agent=owners.get(spec.id, ""),
                pose=(state.x[i], state.y[i], state.heading[i]),
                rolled=(state.rolled_left[i], state.rolled_right[i]),
                collided=state.collided[i],
            )
        )
    return WorldSnapshot(
        tick=state.tick if state is not None else 0,
        revision=max(info.revision, state.revision if state is not None else 0),
        running=running,
        robots=tuple(robots),
        obstacles=tuple(info.obstacles),
    )


def resume(core: WorldCore, snap: WorldSnapshot, now_ns: int) -> None:
    """Puts a new world (its obstacles already placed) in a snapshot's state.

    Each robot is commanded what its motors give until its agent answers again. Every robot with
    an agent counts as lost from ``now_ns`` until its agent's liveliness token
    is seen (at once when the agent is still there): one whose agent died meanwhile is removed
    after the grace period, as if the world had seen it go. The first tick excuses the time the
    world was down, as after a pause, so no watchdog fires for it.

    Args:
        core: A world that has not ticked and has no robot.
        snap: The snapshot.
        now_ns: Monotonic time now.
    """
    reg = core.registry
    for r in snap.robots:
        e = reg.add(spec_from_msg(r.spec), r.agent, now_ns, pose=r.pose)
        # lock-step: nor is the next tick waited for. Its readings may already have gone out
        # (the sensors publish on a confirming verdict, before the state) and been answered to
        # the world that died: its agent would not answer that tick again
        e.last_action_tick = snap.tick + 1
        if r.agent:
            e.lost_ns = now_ns
    core._build()
    out = np.array([_motors(r, core) for r in snap.robots]).reshape(-1, 2)
    collided = np.array([r.collided for r in snap.robots], dtype=bool)
    core.state = replace(core.state, tick=snap.tick, motor_out=out, collided=collided)
    for e, (left, right) in zip(reg.entries.values(), out, strict=True):
        # a chair goes on as it went until its agent's next answer (a command is sticky: the
        # motors' outputs are what it last asked for, once they caught up)
        e.cmd = (float(left), float(right))
    core.revision = snap.revision + 1
    core.presence.forget()
    core.running = snap.running
    core._paused = True  # the time the world was down is not the agents' silence


def _motors(r: SnapshotRobot, core: WorldCore) -> tuple[float, float]:
    """A robot's motor outputs from how far its wheels rolled in the last tick (the inverse of
    what :func:`core.world.propose` rolls)."""
    left, right = r.rolled
    if Profile(core.cfg.profile) == Profile.CIBERRATO:
        return left, right
    dt_s = core.cfg.period_ms / 1000.0
    max_speed = spec_from_msg(r.spec).max_speed_mps
    if dt_s <= 0 or max_speed <= 0:
        return 0.0, 0.0
    k = MAX_POWER / (max_speed * dt_s)
    return left * k, right * k
