"""The legacy games of the bridge's robots, stepped from the world's committed states, and the
robot states legacy viewers are told (the bridge's robots and the native ones alike)."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Mapping

from iw_zenoh.convert import lab_from_msg
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.params import SimParameters
from iw_zenoh.messages import LabMsg, Verdict, WorldInfo, WorldState

from .codec import build_robot_state
from .robot import LegacyRobot
from .scoring import FreeSpace, Mode, PathLength, RobotGame

__all__ = ["HITS_KEPT", "Referee"]

HITS_KEPT = 20  # ticks of verdicts kept for the states that follow them


class Referee:
    """Every legacy robot's game, and the native robots' collision counts.

    Args:
        params: The legacy parameters (SimTime, penalties).
        scoring: The legacy scoring mode.
        world_info: The world's description, or None while it is unknown.
    """

    def __init__(self, params: SimParameters, scoring: Mode, world_info: Callable[[], WorldInfo | None]) -> None:
        self.params = params
        self.scoring = scoring
        self.world_info = world_info
        self._hits: dict[int, dict[int, tuple[bool, bool]]] = {}  # tick -> robot -> (wall, robot)
        self._space: tuple[LabMsg, list[FreeSpace]] | None = None
        self._hit: dict[int, bool] = {}  # native robots: in contact at the last state
        self._collisions: dict[int, int] = {}  # native robots: collisions counted here
        self.finished_at: int | None = None  # the simulator's Time frozen at SimTime, once reached

    def on_verdict(self, v: Verdict) -> None:
        """Notes which collisions of a tick were walls and which robots."""
        kinds: dict[int, tuple[bool, bool]] = {}
        for hit in v.hits:
            wall, robot = kinds.get(hit.robot_id, (False, False))
            kinds[hit.robot_id] = (wall or hit.wall >= 0, robot or hit.other >= 0)
        self._hits[v.tick] = kinds
        for old in [t for t in self._hits if t < v.tick - HITS_KEPT]:
            del self._hits[old]

    def game(self, robot: LegacyRobot) -> RobotGame | None:
        """The robot's legacy game, made once the world's lab is known."""
        if robot.game is None:
            info = self.world_info()
            if info is None:
                return None
            p = self.params
            robot.game = RobotGame(
                lab_from_msg(info.lab),
                mode=self.scoring,
                sim_time=p.sim_time,
                wall_penalty=p.collision_wall_penalty,
                robot_penalty=p.collision_robot_penalty,
                start=robot.start,
            )
        return robot.game

    def _free_space(self, info: WorldInfo | None) -> FreeSpace | None:
        """The lab's free space for D(p), built once in a thread of its own (part of a second for
        a Ciber-Rato lab, and the UDP loop must not stall); None until it is ready."""
        if info is None:
            return None
        if self._space is None or self._space[0] != info.lab:
            box: list[FreeSpace] = []
            lab = lab_from_msg(info.lab)
            t = threading.Thread(target=lambda: box.append(FreeSpace(lab)), name="free-space", daemon=True)
            self._space = (info.lab, box)
            t.start()
        return self._space[1][0] if self._space[1] else None

    def step(self, st: WorldState, robots: Mapping[int, LegacyRobot], info: WorldInfo | None) -> None:
        """One committed step of every legacy robot's state machine and score.

        Args:
            st: The world's committed state.
            robots: The bridge's robots by id.
            info: The world's description as last received.
        """
        hits = self._hits.pop(st.tick, {})
        for rid, x, y, hit in zip(st.ids, st.x, st.y, st.collided, strict=True):
            robot = robots.get(rid)
            game = self.game(robot) if robot is not None else None
            if robot is None or game is None:
                continue
            if game.path is None and self.scoring != Mode.CONTROL:
                space = self._free_space(info)
                if space is not None:
                    game.path = PathLength(game.lab, robot.start, space=space)
            wall, other = hits.get(rid, (hit, False))
            robot.step(st.tick, x, y, collision=hit, hit_wall=wall, hit_robot=other)

    def finish(self, tick: int, info: WorldInfo | None, robots: Mapping[int, LegacyRobot]) -> bool:
        """Whether the simulation finishes at ``tick``: Ciber-Rato's simulator finishes when its
        Time reaches SimTime (SimTime > 0), in a world of the ciberrato profile; robots and viewers
        then go on receiving every cycle with Time frozen and both buttons Off, Start is ignored,
        and every robot stops.

        Args:
            tick: A committed state's tick.
            info: The world's description as last received.
            robots: The bridge's robots by id.

        Returns:
            True once, at the tick it finishes (the world is then to be paused for good).
        """
        sim_time = self.params.sim_time
        if self.finished_at is not None or sim_time <= 0 or tick < sim_time:
            return False
        if info is None or info.profile != Profile.CIBERRATO:
            return False  # a native world's length is its own (a legacy viewer may watch a long run)
        self.finished_at = sim_time
        for robot in robots.values():
            robot.left = robot.right = 0.0
        return True

    def robot_states(
        self, st: WorldState, robots: Mapping[int, LegacyRobot], info: WorldInfo | None, *, running: bool
    ) -> list[bytes]:
        """What legacy viewers are told of every robot of a committed state.

        Args:
            st: The state.
            robots: The bridge's robots by id.
            info: The world's description as last received.
            running: Whether the simulator runs (a native robot's state).
        """
        specs = {s.id: s.name for s in (info.robots if info else [])}
        out = []
        natives: list[int] = []  # the native robots of this state
        for rid, x, y, h, hit in zip(st.ids, st.x, st.y, st.heading, st.collided, strict=True):
            robot = robots.get(rid)
            g = robot.game if robot is not None else None
            if g is None:  # a native robot: no legacy game, its collisions counted here
                natives.append(rid)
                if hit and not self._hit.get(rid, False):
                    self._collisions[rid] = self._collisions.get(rid, 0) + 1
                self._hit[rid] = hit
            out.append(
                build_robot_state(
                    name=(robot.name if robot is not None else "") or specs.get(rid, f"robot{rid}"),
                    robot_id=rid,
                    time=st.tick,
                    x=x,
                    y=y,
                    dir_deg=math.degrees(h),
                    collision=hit,
                    collisions=g.collisions if g is not None else self._collisions.get(rid, 0),
                    state=g.state if g is not None else ("Running" if running else "Stopped"),
                    score=g.score if g is not None else 0,
                    arrival_time=g.arrival_time if g is not None else st.tick,
                    returning_time=g.returning_time if g is not None else 0,
                    visited_mask=g.visited_mask if g is not None else "0" * len(info.lab.targets if info else ()),
                )
            )
        if len(self._hit) > len(natives):
            self._forget(natives)
        return out

    def _forget(self, natives: list[int]) -> None:
        """Forgets the native robots a state no longer holds (removed: their counts go with them)."""
        here = set(natives)
        self._hit = {rid: v for rid, v in self._hit.items() if rid in here}
        self._collisions = {rid: n for rid, n in self._collisions.items() if rid in here}
