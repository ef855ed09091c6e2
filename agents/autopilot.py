"""The wheelchair's autonomous driving, pure: plan on the known map, follow the plan, map what
the sonars find, replan when the plan is blocked.

* Planning: hybrid A* over (x, y, heading) for the chair's own rectangle
  (:mod:`iw_zenoh.core.poseplan`): the known walls grown by the chair's outline at each heading
  (the configuration space, as ViRBot grows walls by its robot's radius, but for a rectangle
  that turns about a point near its front axle).
* Following: pure pursuit on the planned poses, turning on the spot where the plan does
  (:mod:`iw_zenoh.agents.pursuit`).
* Mapping: every tick the cones carve free space, and a reading nearer than the known map
  explains (the chair predicts each cone's reading on its map) marks its arc
  (:mod:`iw_zenoh.core.sonarmap`); when a marked cell makes the rest of the plan collide, the
  chair stops and plans again with what it has seen grown in.
* Reactive safety: something nearer than ``stop_m`` ahead (a chair crossing, a closing door)
  stops the chair whatever the plan says; it goes on once the way is clear, and plans again if
  it stays blocked.
* Guard: no command is sent whose next ``GUARD_S`` would bring the chair's bare outline onto
  its map where it is not already (the follower strays from what the planner checked: a
  corrective turn on the spot swings the front 0.84 m out); the chair stops and plans again.
* Tight spots: the plan may back up (straight, dearly), and a chair that stands inside its own
  margin plans from there with its bare outline; one that the lattice has touching although its
  real outline is clear (a few degrees off a plan in a tight gap) plans from the nearest lattice
  pose a short turn or move reaches (:mod:`iw_zenoh.agents.outline`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.lab import Lab, Scene
from iw_zenoh.core.poseplan import Footprint, PoseSpace, occupancy, pose_plan
from iw_zenoh.core.sensors import proximity_distances
from iw_zenoh.core.sonarmap import Cone, SonarMap
from iw_zenoh.core.spec import RobotSpec

from .mapping_chair import MAPPING_SENSORS, cones_of, mapping_chair
from .outline import arc_poses, sweeps_onto, ways_out
from .pursuit import Drive, backing, follow, slowed

__all__ = ["MAPPING_SENSORS", "Autopilot", "Drive", "cones_of", "mapping_chair"]

FloatArray = npt.NDArray[np.float64]

CELL_M = 0.05
MARK_M = 1.5  # narrow cones: a reading this near marks its arc (5 degrees at 1.5 m is 0.13 m); farther ones carve
GUARD_S = 0.3  # look this far ahead in time for a motion that would touch the map
BACK_STOP_M = 0.2  # backing up: stop when something unexplained is this near behind
WINDOW_M = 4.0  # plan inside the box round start and goal grown by this much (the whole lab if that fails)
BLOCKED_REPLAN_TICKS = 20  # stopped by something ahead this long: plan again round it
PLAN_EXPAND = 30_000  # give up a plan after this many states (about 2 s here)
EXPLAINED_M = (0.1, 0.08)  # a reading within a + b * d of what the known map predicts is the map, not news
NO_PATH_RETRY_TICKS = 20  # no path: stand still and look this long, then try again
FORGET_AFTER_FAILS = 3  # this many failed plans in a row: forget what the sonars marked


@dataclass
class Autopilot:
    """Plans and follows a path to a goal for one chair.

    Args:
        spec: The chair (outline, centre of movement, sensors).
        known: The map the chair knows (walls; closed doors count as walls).
        margin_m: Kept clear of everything, on every side.
        reach_m: The goal counts as reached this near.
        stop_m: Stop when something is nearer than this ahead.
        movers: (x, y, radius) places where something known moves (a door's leaf): not mapped.
        careful: For tight floors (1.1 m doorways): slow down near things and correct
            deviations by arcs, not turns on the spot (use with a 5 cm margin).
    """

    spec: RobotSpec
    known: Lab
    margin_m: float = 0.04
    careful: bool = False
    reach_m: float = 0.35
    stop_m: float = 0.3
    goal: tuple[float, float] | None = None
    path: FloatArray | None = None
    index: int = 0
    replans: int = 0
    blocked_ticks: int = 0
    status: str = "idle"
    _occ: npt.NDArray[np.bool_] = field(init=False, repr=False)
    _space: PoseSpace | None = field(default=None, init=False, repr=False)
    _replan: bool = field(default=False, init=False, repr=False)
    _wait: int = field(default=0, init=False, repr=False)
    _fails: int = field(default=0, init=False, repr=False)
    movers: list[tuple[float, float, float]] = field(default_factory=list)
    _unwrapped: FloatArray = field(default_factory=lambda: np.zeros(0), init=False, repr=False)
    _back: npt.NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool), init=False, repr=False)
    sonar: SonarMap = field(init=False, repr=False)
    fp: Footprint = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._occ = occupancy(self.known, CELL_M)
        self.sonar = SonarMap(self._occ, CELL_M, mark_m=MARK_M)
        self.fp = Footprint.of(self.spec.width_m, self.spec.height_m, self.spec.com, self.margin_m)
        self._bare = Footprint.of(self.spec.width_m, self.spec.height_m, self.spec.com, 0.0)
        self._bare_points = self._bare.points(0.5 * CELL_M)
        self._front = {m.id for m in self.spec.sensors if abs(m.angle_deg) <= 10.0}
        self._rear = {m.id for m in self.spec.sensors if abs(m.angle_deg) >= 150.0}
        self._scene = Scene(self.known)
        self._bodies = Bodies.from_specs([self.spec])
        self._sensor_ids = self._bodies.ir_id.tolist()

    def expected(self, pose: tuple[float, float, float]) -> dict[int, float]:
        """What each cone would read on the known map at a pose (x, y, heading deg)."""
        p = np.array([[pose[0], pose[1], math.radians(pose[2])]])
        d = proximity_distances(self._scene, self._bodies, p)
        return dict(zip(self._sensor_ids, d.tolist(), strict=True))

    def unexplained(
        self, pose: tuple[float, float, float], ids: list[int], dists: list[float | None]
    ) -> list[float | None]:
        """The readings with what the known map explains replaced by "nothing there": a cone
        still carves free space up to its reading, but only news marks an arc."""
        exp = self.expected(pose)
        return [
            None if d is None or d >= exp.get(i, math.inf) - EXPLAINED_M[0] - EXPLAINED_M[1] * d else d
            for i, d in zip(ids, dists, strict=True)
        ]

    def set_goal(self, goal: tuple[float, float]) -> None:
        """A new goal: the next step plans to it."""
        self.goal = goal
        self.path = None
        self.status = "planning"

    def _at_mover(self, cone: Cone, d: float) -> bool:
        """Whether a reading hits where a known mover is (a door's leaf)."""
        hx, hy = cone.x + d * math.cos(cone.angle_rad), cone.y + d * math.sin(cone.angle_rad)
        return any((hx - mx) ** 2 + (hy - my) ** 2 <= mr**2 for mx, my, mr in self.movers)

    def passes_near(self, x: float, y: float, within_m: float) -> bool:
        """Whether the rest of the plan passes within ``within_m`` of (x, y)."""
        if self.path is None:
            return False
        rest = self.path[self.index :]
        return bool(np.any((rest[:, 0] - x) ** 2 + (rest[:, 1] - y) ** 2 <= within_m**2))

    def arrived(self, pose: tuple[float, float, float]) -> bool:
        """Whether the chair is at its goal."""
        return (
            self.goal is not None and math.hypot(self.goal[0] - pose[0], self.goal[1] - pose[1]) <= self.reach_m + 0.1
        )

    def _attempts(
        self, pose: tuple[float, float, float]
    ) -> list[tuple[Footprint, tuple[float, float, float, float] | None, npt.NDArray[np.bool_]]]:
        """The searches :meth:`_plan` tries in turn: (footprint, window or None, marks)."""
        assert self.goal is not None
        (x0, x1), (y0, y1) = sorted((pose[0], self.goal[0])), sorted((pose[1], self.goal[1]))
        box = (x0 - WINDOW_M, y0 - WINDOW_M, x1 + WINDOW_M, y1 + WINDOW_M)
        whole = box[0] <= 0 and box[1] <= 0 and box[2] >= self.known.width_m and box[3] >= self.known.height_m
        # with every mark first; if that leaves no way, with the confirmed (near) ones only
        # (far arcs are wide and the chair will see better when nearer)
        seen = [self.sonar.occupied]
        if not np.array_equal(self.sonar.occupied, self.sonar.confirmed):
            seen.append(self.sonar.confirmed)
        # the chair's margin first: in the window, then the whole lab; when the chair itself is
        # inside its margin (squeezed between two things, or pushed there by the follower), once
        # more in the window without it (the last one): the bare outline still never touches
        # what is mapped, and the next plan from a roomier pose has its margin again. At most
        # four searches, so a plan stays within seconds even when there is no way.
        attempts: list[tuple[Footprint, tuple[float, float, float, float] | None, npt.NDArray[np.bool_]]]
        attempts = [(self.fp, box, occ) for occ in seen]
        if not whole:
            attempts.append((self.fp, None, seen[0]))
        return [*attempts, (self._bare, box, seen[0])]

    def _plan(self, pose: tuple[float, float, float]) -> None:
        assert self.goal is not None
        start = (pose[0], pose[1], math.radians(pose[2]))
        attempts = self._attempts(pose)
        fits = squeezed = False
        for i, (fp, window, occ_seen) in enumerate(attempts):
            last = i == len(attempts) - 1
            if last and fits:
                break  # the margin was not what stood in the way
            if fp is self.fp and squeezed:
                continue  # the same cells round the chair in every window: no need to look again
            space = PoseSpace(self._occ | occ_seen, CELL_M, fp, window=window)
            if space.free(*start):
                fits = fits or fp is self.fp
                found = pose_plan(space, start, self.goal, reach_m=self.reach_m, max_expand=PLAN_EXPAND)
                poses = None if found is None else found.poses
            elif last:
                poses = self._plan_out(space, start)  # the lattice has even the bare outline touching
            else:
                squeezed = squeezed or (fp is self.fp and occ_seen is self.sonar.occupied)
                continue
            if poses is not None:
                self._space, self.path, self.index = space, poses, 0
                self._unwrapped = np.unwrap(poses[:, 2])
                self._back = backing(poses)
                self.status = "driving"
                return
        self._space, self.path = None, None
        self.status = "no path"

    def _plan_out(self, space: PoseSpace, start: tuple[float, float, float]) -> FloatArray | None:
        """A plan for a chair that stands where the lattice (heading steps of 7.5 degrees, 5 cm
        cells) has even its bare outline touching, though its real outline may touch nothing: a
        chair that follows a plan a few degrees off in a tight gap gets there, and planning from
        there would fail for good. Plans from the nearest lattice pose that fits and that a short
        turn or move (:func:`ways_out`) reaches without bringing the real outline onto the map;
        the path starts with that move. None when there is no such pose or no plan from it.
        """
        assert self.goal is not None
        for move in ways_out(start):
            end = (float(move[-1, 0]), float(move[-1, 1]), float(move[-1, 2]))
            if not space.free(*end) or sweeps_onto((self._occ, self.sonar.occupied), CELL_M, self._bare_points, move):
                continue
            found = pose_plan(space, end, self.goal, reach_m=self.reach_m, max_expand=PLAN_EXPAND)
            return None if found is None else np.vstack([move[:-1], found.poses])
        return None

    def step(
        self, pose: tuple[float, float, float], ids: list[int], dists: list[float | None], *, collided: bool = False
    ) -> Drive:
        """One tick: map, check the plan, follow it. Pose is (x, y, heading deg)."""
        news, cones, new = self._map(pose, ids, dists)
        held = self._ready(pose)
        if held is not None:
            return held
        if len(new) and self._plan_meets(new):
            self.replans += 1
            self._replan = True  # stop now, plan next tick (a plan may take a while)
            return Drive(0.0, 0.0, "replanning")
        drive = self._follow(pose)
        if self._blocked(ids, news, cones, drive, collided=collided):
            return Drive(0.0, 0.0, "blocked")
        if drive.status == "driving" and self.careful:
            drive = slowed(drive, dists)
        if self.touches(pose, drive):
            # the follower strays from what the plan checked (a corrective turn on the spot swings
            # the front 0.84 m out): never into what is mapped; stop and plan from here
            self.replans += 1
            self._replan = True
            return Drive(0.0, 0.0, "guarded")
        return drive

    def _map(
        self, pose: tuple[float, float, float], ids: list[int], dists: list[float | None]
    ) -> tuple[list[float | None], list[Cone], FloatArray]:
        """Maps one tick's readings: every reading carves, only the unexplained ones mark, and
        nothing is marked where a known mover is.

        Returns:
            The unexplained readings, the cones and the centres (K, 2) of newly marked cells.
        """
        news = self.unexplained(pose, ids, dists)
        cones = cones_of(self.spec, pose, ids, dists)
        # carve with every reading, mark only with the unexplained ones
        cones = [
            c if n is not None or c.distance_m is None else replace(c, mark=False)
            for c, n in zip(cones, news, strict=True)
        ]
        new = self.sonar.update(cones)
        if self.movers and len(new):
            keep = np.ones(len(new), dtype=bool)
            for mx, my, mr in self.movers:
                inside = (new[:, 0] - mx) ** 2 + (new[:, 1] - my) ** 2 <= mr**2
                keep &= ~inside
                cells = (new[inside] / CELL_M).astype(np.int64)
                self.sonar.occupied[cells[:, 1], cells[:, 0]] = False
            new = new[keep]
        return news, cones, new

    def _ready(self, pose: tuple[float, float, float]) -> Drive | None:
        """None when there is a plan to follow this tick (planning first if one is due), else
        the standstill: idle, arrived, waiting after a failed plan, or no path (after too many,
        the sonar marks are forgotten)."""
        if self.goal is None or self.arrived(pose):
            self.status = "arrived" if self.goal is not None else "idle"
            return Drive(0.0, 0.0, self.status)
        if self._wait > 0:
            self._wait -= 1
            return Drive(0.0, 0.0, self.status)
        if self._replan or self.path is None:
            self._replan = False
            self._plan(pose)
        if self.path is None or self._space is None:
            self._fails += 1
            self._wait = NO_PATH_RETRY_TICKS
            if self._fails >= FORGET_AFTER_FAILS:
                self._fails = 0
                self.sonar.occupied[:] = False  # the marks may be wrong: look again
            return Drive(0.0, 0.0, self.status)
        self._fails = 0
        return None

    def _plan_meets(self, new: FloatArray) -> bool:
        """Grows newly marked cells (K, 2) into the plan's space; whether the rest of the plan
        now collides with them."""
        assert self._space is not None
        assert self.path is not None
        self._space.add_points(new)
        ahead = self.path[self.index :]
        return not np.all(self._space.path_free(ahead[:: max(1, len(ahead) // 200)]))

    def _blocked(
        self, ids: list[int], news: list[float | None], cones: list[Cone], drive: Drive, *, collided: bool
    ) -> bool:
        """Reactive safety: whether something unexplained is too near where the drive goes (or the
        chair collided); held this long, a new plan is asked for."""
        # something close ahead that neither map explains (it moved in, or was missed) stops
        # forward motion; what is mapped the plan already keeps clear of
        front = min(
            (
                d
                for i, d, cone in zip(ids, news, cones, strict=True)
                if d is not None
                and i in self._front
                and d < self.sonar.nearest(cone) - EXPLAINED_M[0]
                and not self._at_mover(cone, d)
            ),
            default=math.inf,
        )
        behind = min((d for i, d in zip(ids, news, strict=True) if d is not None and i in self._rear), default=math.inf)
        forward = drive.left_mps + drive.right_mps > 0.0
        backing = drive.status == "backing"
        if (front < self.stop_m and forward) or (behind < BACK_STOP_M and backing) or collided:
            self.blocked_ticks += 1
            if self.blocked_ticks >= BLOCKED_REPLAN_TICKS:
                self.blocked_ticks = 0
                self.replans += 1
                self._replan = True
            return True
        self.blocked_ticks = 0
        return False

    def touches(self, pose: tuple[float, float, float], drive: Drive) -> bool:
        """Whether the next ``GUARD_S`` of this drive would bring the chair's bare outline onto a
        cell of its map (known walls or marks) that it does not already overlap."""
        if drive.left_mps == 0.0 and drive.right_mps == 0.0:
            return False
        v = 0.5 * (drive.left_mps + drive.right_mps)
        w = (drive.right_mps - drive.left_mps) / self.spec.height_m
        poses = arc_poses((pose[0], pose[1], math.radians(pose[2])), v, w, GUARD_S, 4)
        return sweeps_onto((self._occ, self.sonar.occupied), CELL_M, self._bare_points, poses)

    def _follow(self, pose: tuple[float, float, float]) -> Drive:
        assert self.path is not None
        drive, self.index = follow(
            self.path, self._unwrapped, self._back, self.index, pose, base_m=self.spec.height_m, careful=self.careful
        )
        if drive.status == "replanning":
            self._replan = True  # the plan is used up short of the goal: plan the rest
        return drive
