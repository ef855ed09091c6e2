"""The world's roster: who is registered, with which spec, driven by which agent, commanding
what; the rules that accept or refuse a registration; and the order of the arrays a tick steps."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np
import shapely

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.lab import Grid, Scene
from iw_zenoh.core.spec import MAX_BODY_M, RobotSpec, RobotType
from iw_zenoh.core.world import WorldState

__all__ = ["MAX_ROBOTS", "MAX_ROBOTS_PER_AGENT", "MAX_ROBOT_ID", "Entry", "Registry", "Refused"]

MAX_ROBOT_ID = 2**31 - 1  # far below 64 bits: ids are summed, numbered on and kept in int64 arrays
_REACH_M = 3 * MAX_BODY_M  # two bodies whose poses are farther apart than this cannot touch (corners: 11.2 m)
MAX_ROBOTS = 10_000  # in one world (the largest benchmarked: 10,000 chairs)
SHAPES_KEPT = MAX_ROBOTS  # robots' bodies kept for moves and placement checks (a removed one's dropped)
MAX_ROBOTS_PER_AGENT = 2_000  # registered under one agent name (a host of 1,000 chairs is benchmarked)


class Refused(Exception):
    """A registration the world refuses; the message is the reason sent back."""


@dataclass
class Entry:
    """One registered robot.

    Attributes:
        spec: The accepted spec, with its id and start pose.
        agent: Liveliness name of the agent process driving it ("" for none).
        cmd: Last commanded powers (left, right).
        last_action_ns: Monotonic time of its last actions (or of its registration).
        last_action_tick: The sensors tick its last actions answered (-1: none yet).
        watchdog: True while its motors are zeroed for want of fresh actions.
        lost_ns: When its agent was lost (for removal after the grace period), or None.
        report: Last reported pose of a Real robot (x, y, heading rad), or None.
        instance: Which run of its agent process registered it (the first part of the request
            id, the process id): the same agent name from another process is its agent restarted.
        dropped: Its agent's token went away since it registered (a process stopped past its
            lease): the same process asking for it again gets it back.
    """

    spec: RobotSpec
    agent: str = ""
    cmd: tuple[float, float] = (0.0, 0.0)
    last_action_ns: int = 0
    last_action_tick: int = -1
    watchdog: bool = False
    lost_ns: int | None = None
    report: tuple[float, float, float] | None = None
    leds: dict[str, bool] = field(default_factory=dict)
    instance: str = ""
    dropped: bool = False  # its agent's token went away since it registered (it may ask again)


class Registry:
    """Robots by id, in registration order (the order of every batched array).

    A robot that registers or leaves changes the roster at once, but the arrays a tick steps are
    rebuilt once, when the next tick begins (:meth:`arrange`): a thousand robots registering one
    by one rebuilt them a thousand times, minutes.
    """

    def __init__(self, scene: Scene, grid: Grid) -> None:
        self.scene = scene
        self.grid = grid
        self.entries: dict[int, Entry] = {}
        self.arrayed: list[int] = []  # robot ids in the order of the arrays last built
        self._stale = False  # the roster changed since the arrays were built
        self._new_poses: dict[int, np.ndarray] = {}  # start poses of robots not yet in the arrays
        self.per_agent: Counter[str] = Counter()  # robots registered under each agent name
        self._shapes: dict[int, tuple[RobotSpec, Bodies]] = {}  # a moved robot's body, while its spec stays

    @property
    def ids(self) -> list[int]:
        """Robot ids in array order."""
        return list(self.entries)

    def specs(self) -> list[RobotSpec]:
        """Accepted specs in array order."""
        return [e.spec for e in self.entries.values()]

    def _free_id(self, skip: set[int]) -> int:
        for k in range(1, len(self.grid.positions) + 1):
            if k not in self.entries and k not in skip:
                return k
        raise Refused(
            f"the grid is full: all {len(self.grid.positions)} start positions are taken; "
            "give X and Y, or remove a robot"
        )

    def _next_id(self, skip: set[int]) -> int:
        """The id of a robot placed by its pose: past the grid and every id taken, or (that being
        past :data:`MAX_ROBOT_ID`) the first free one past the grid."""
        k = max([0, len(self.grid.positions), *self.entries, *skip]) + 1
        if k <= MAX_ROBOT_ID:
            return k
        last = MAX_ROBOT_ID + 1
        return next(k for k in range(len(self.grid.positions) + 1, last) if k not in self.entries and k not in skip)

    def _id_for(self, spec: RobotSpec, skip: set[int]) -> int:
        """The id a new robot gets (the one asked, or a free one for 0), within the bounds."""
        if spec.id > MAX_ROBOT_ID:
            raise Refused(f"id {spec.id} is beyond the largest robot id, {MAX_ROBOT_ID}; ask for a smaller one or 0")
        if len(self.entries) >= MAX_ROBOTS:
            raise Refused(f"the world holds {MAX_ROBOTS} robots, the most it takes; remove one first")
        if spec.id:
            return spec.id
        return self._free_id(skip) if spec.x_m is None else self._next_id(skip)

    def place(
        self,
        spec: RobotSpec,
        pose: dict[int, tuple[float, float, float]],
        *,
        skip: set[int] | None = None,
        on_robots: bool = False,
    ) -> RobotSpec:
        """Chooses the id and start pose of a new robot, or refuses it.

        Args:
            spec: The requested spec.
            pose: Current poses of the registered robots (x, y, heading rad) by id.
            skip: Ids not given to a robot asking for any (0): the scenario's, for its agents.
            on_robots: Accept a start on other robots' bodies, as the legacy simulator does (the
                ciberrato profile: the Ciber2001 grid's starts are 1.0 apart, three touching discs).

        Returns:
            The spec with id and pose set.

        Raises:
            Refused: Duplicate id, full grid, id beyond the grid without a pose, or a start pose
                outside the lab, inside a wall or on another robot.
        """
        rid = self._id_for(spec, skip or set())
        if rid in self.entries:
            raise Refused(
                f"id {rid} is taken by {self.entries[rid].spec.name!r}; ask for another id or 0 for the first free one"
            )
        if spec.x_m is None or spec.y_m is None:
            if rid > len(self.grid.positions):
                raise Refused(f"id {rid} is beyond the grid's {len(self.grid.positions)} start positions; give X and Y")
            g = self.grid.positions[rid - 1]
            x, y, d = g.x, g.y, g.dir_deg
        else:
            x, y = spec.x_m, spec.y_m
            d = spec.dir_deg if spec.dir_deg is not None else 0.0
        if spec.dir_deg is not None:
            d = spec.dir_deg
        placed = spec.placed(rid, x, y, d)
        self.check_free(placed, pose, on_robots=on_robots)
        return placed

    def check_free(
        self,
        placed: RobotSpec,
        pose: dict[int, tuple[float, float, float]],
        *,
        on_robots: bool = False,
        shape: Bodies | None = None,
    ) -> None:
        """Refuses a body at its spec's start pose outside the lab, on a wall (not for a door), or
        on one of the robots of ``pose`` (unless ``on_robots``). ``shape``: the spec's body
        (:meth:`shape`, of a robot moved), else built from the spec.

        Raises:
            Refused: Why the place is not free.
        """
        x, y, d = placed.x_m or 0.0, placed.y_m or 0.0, placed.dir_deg or 0.0
        lab = self.scene.lab
        if not (0.0 < x < lab.width_m and 0.0 < y < lab.height_m):
            raise Refused(f"start ({x:g}, {y:g}) is outside the lab ({lab.width_m:g} x {lab.height_m:g})")
        body = Bodies.from_specs([placed]) if shape is None else shape
        poly = shapely.polygons(body.world_outline(np.array([[x, y, np.radians(d)]])))[0]
        if placed.type != RobotType.DOOR:
            hit = self.scene.wall_tree.query(poly, predicate="intersects")
            if len(hit):
                raise Refused(f"start ({x:g}, {y:g}) puts the body on wall {int(hit[0])}; choose a free place")
        other = None if on_robots else self._robot_under(placed, poly, (x, y), pose)
        if other is not None:
            raise Refused(f"start ({x:g}, {y:g}) puts the body on robot {other}; choose a free place")

    def shape(self, robot_id: int) -> Bodies:
        """A registered robot's body alone (built once while its spec stays: a learning
        environment moves its chairs thousands of times, and a body cost half a millisecond)."""
        spec = self.entries[robot_id].spec
        got = self._shapes.get(robot_id)
        if got is None or got[0] is not spec:
            if len(self._shapes) >= SHAPES_KEPT:  # a bounded table: start again (robots gone, a flood)
                self._shapes = {}
            got = self._shapes[robot_id] = (spec, Bodies.from_specs([spec]))
        return got[1]

    def _robot_under(
        self,
        placed: RobotSpec,
        poly: shapely.Polygon,
        at: tuple[float, float],
        pose: dict[int, tuple[float, float, float]],
    ) -> int | None:
        """The robot a new body at ``poly`` would lie on, if any. Only robots near enough to touch
        it are checked (a body is within MAX_BODY_M of its pose): checking every robot made each
        registration of a flood slower than the last; a revolving door's leaves share its hub."""
        x, y = at
        others = [(i, q) for i, q in pose.items() if abs(q[0] - x) <= _REACH_M and abs(q[1] - y) <= _REACH_M]
        if placed.type == RobotType.DOOR:
            others = [(i, q) for i, q in others if i not in self.entries or self.entries[i].spec.type != RobotType.DOOR]
        if not others:
            return None
        # each body alone (kept while its spec stays: outlines of different lengths do not stack)
        polys = [shapely.polygons(self.shape(i).world_outline(np.array([q])))[0] for i, q in others]
        touching = np.flatnonzero(shapely.intersects(polys, poly))
        return others[int(touching[0])][0] if len(touching) else None

    def add(self, spec: RobotSpec, agent: str, now_ns: int, *, pose: tuple[float, float, float] | None = None) -> Entry:
        """Adds an accepted robot (placed: its id and start pose set).

        Args:
            spec: The placed spec.
            agent: Liveliness name of its agent ("" for none).
            now_ns: Monotonic time now.
            pose: Where it is (x, y, heading rad), when not at its start pose (a resumed world).
        """
        e = Entry(spec=spec, agent=agent, last_action_ns=now_ns)
        self.remove(spec.id)
        self.per_agent[agent] += 1
        self.entries[spec.id] = e
        start = (spec.x_m or 0.0, spec.y_m or 0.0, float(np.radians(spec.dir_deg or 0.0)))
        self._new_poses[spec.id] = np.array(pose if pose is not None else start)
        self._stale = True
        return e

    def reclaimable(self, spec: RobotSpec, agent: str, instance: str) -> int | None:
        """The robot a restarted agent asks for again, or None: one registered by the same agent
        name from another process (another ``instance``), or from the same process once its token
        went away (the agent was stopped past its lease: its old body is its own), with the
        id asked (or, for id 0, the same name). Its robot keeps its id and place instead of being
        refused as a duplicate or as on another robot.
        """
        if not agent or not instance:
            return None
        for rid, e in self.entries.items():
            if e.agent != agent or e.instance == instance and not e.dropped:
                continue
            if rid == spec.id if spec.id else e.spec.name == spec.name:
                return rid
        return None

    def reclaim(self, robot_id: int, state: WorldState, now_ns: int) -> tuple[Entry, RobotSpec]:
        """Hands a robot to its restarted agent: alive again, no command yet; with its spec
        placed where it is now (the registration's answer)."""
        e = self.entries[robot_id]
        x, y, h = self.poses(state)[robot_id]
        e.lost_ns, e.cmd, e.last_action_ns, e.dropped = None, (0.0, 0.0), now_ns, False
        return e, e.spec.placed(robot_id, x, y, float(np.degrees(h)))

    def remove(self, robot_id: int) -> Entry | None:
        """Removes a robot; returns it, or None if there was none."""
        e = self.entries.pop(robot_id, None)
        self._shapes.pop(robot_id, None)
        if e is not None:
            self._stale = True
            self.per_agent[e.agent] -= 1
            if not self.per_agent[e.agent]:
                del self.per_agent[e.agent]
        return e

    def poses(self, state: WorldState) -> dict[int, tuple[float, float, float]]:
        """Current pose (x, y, heading rad) of every registered robot by id, newcomers at their
        start pose.

        Args:
            state: The state of the arrays last built.
        """
        out = {
            rid: (float(p[0]), float(p[1]), float(p[2]))
            for rid, p in zip(self.arrayed, state.pose, strict=True)
            if rid in self.entries
        }
        for rid, p in self._new_poses.items():
            if rid in self.entries:
                out[rid] = (float(p[0]), float(p[1]), float(p[2]))
        return out

    def poses_near(self, state: WorldState, x: float, y: float) -> dict[int, tuple[float, float, float]]:
        """The poses of the arrays' robots near enough to (x, y) for a body there to touch them
        (what :meth:`check_free` looks at), by id; the arrays must be current (no newcomer)."""
        p = state.pose
        near = np.flatnonzero((np.abs(p[:, 0] - x) <= _REACH_M) & (np.abs(p[:, 1] - y) <= _REACH_M))
        return {self.arrayed[j]: (float(p[j, 0]), float(p[j, 1]), float(p[j, 2])) for j in near.tolist()}

    def arrange(self, state: WorldState) -> tuple[WorldState, Bodies] | None:
        """The arrays for the current roster when it changed since they were last built, keeping
        every surviving robot's pose, motor outputs and collision flag; None when it did not.

        Args:
            state: The state of the arrays last built.

        Returns:
            The state in the new order (commands and distances rolled zero) and its bodies.
        """
        if not self._stale:
            return None
        self._stale = False
        keep_pose, self._new_poses = self._new_poses, {}
        old = {rid: i for i, rid in enumerate(self.arrayed)}
        ids = self.ids
        n = len(ids)
        pose = np.zeros((n, 3))
        out = np.zeros((n, 2))
        col = np.zeros(n, dtype=bool)
        for i, rid in enumerate(ids):
            if rid in old:
                j = old[rid]
                pose[i] = state.pose[j]
                out[i] = state.motor_out[j]
                col[i] = state.collided[j]
            else:
                pose[i] = keep_pose[rid]
        self.arrayed = ids
        arranged = WorldState(state.tick, pose, out, np.zeros((n, 2)), col, np.zeros((n, 2)))
        return arranged, Bodies.from_specs(self.specs())

    def commands(
        self, ids: list[int], *, now_ns: int, timeout_ns: int | None, answered_tick: int | None
    ) -> tuple[np.ndarray, np.ndarray, list[int]]:
        """What to apply this tick, firing the watchdog of robots whose actions are stale.

        Args:
            ids: Robot ids in array order.
            now_ns: Monotonic time now.
            timeout_ns: Actions older than this are stale (None: never; the last command holds).
            answered_tick: Lock-step: a robot that answered this sensors tick is on time however
                long ago that was (None in real time).

        Returns:
            (N, 2) powers (zero for a robot whose watchdog fired or whose agent is lost), (N, 3)
            reported poses of Real robots (NaN for the others), and the robots whose watchdog
            fired now, in array order.
        """
        cmd = np.zeros((len(ids), 2))
        report = np.full((len(ids), 3), np.nan)
        fired: list[int] = []
        for i, rid in enumerate(ids):
            e = self.entries[rid]
            # lock-step: a robot that answered the last tick is on time however long the
            # others took (a wall-clock watchdog there zeroed a door that had answered while a
            # chair planned, differently each run)
            answered = answered_tick is not None and e.last_action_tick >= answered_tick
            stale = timeout_ns is not None and now_ns - e.last_action_ns > timeout_ns and not answered
            if stale and not e.watchdog and e.lost_ns is None and e.spec.type != RobotType.REAL:
                e.watchdog = True
                fired.append(rid)
            if not (e.watchdog or e.lost_ns is not None):
                cmd[i] = e.cmd
            if e.report is not None:
                report[i] = e.report
        return cmd, report, fired

    def excuse_pause(self, now_ns: int, *, last_tick_ns: int | None) -> None:
        """The world ticks again after a pause: the watchdog counts only time it ran.

        Args:
            now_ns: Monotonic time of the first tick after the pause.
            last_tick_ns: When the last tick before the pause began (None: the world never ran,
                so every robot's silence starts now).
        """
        for e in self.entries.values():
            if last_tick_ns is None:
                e.last_action_ns = max(e.last_action_ns, now_ns)
            else:
                e.last_action_ns += max(0, now_ns - max(last_tick_ns, e.last_action_ns))

    def agent_back(self, agent: str) -> None:
        """An agent is (again) alive: its robots are no longer due for removal."""
        for e in self.entries.values():
            if e.agent == agent:
                e.lost_ns = None

    def agent_lost(self, agent: str, now_ns: int) -> list[int]:
        """An agent is gone: its robots stop at once, due for removal after the grace period.

        Returns:
            The robots newly lost, in registration order.
        """
        lost: list[int] = []
        for rid, e in self.entries.items():
            if e.agent == agent and e.lost_ns is None:
                e.lost_ns, e.dropped = now_ns, True
                e.cmd = (0.0, 0.0)
                lost.append(rid)
        return lost
