"""What a study measures of a run, per chair and for the whole run, from the world's messages.

Pure: a :class:`RunMeter` is handed the recording's world descriptions, committed states and
events in order (``iwz report`` reads them with :func:`~iw_zenoh.record.reader.open_recording`)
and :meth:`RunMeter.finish` gives a :class:`RunReport`. Every robot that is not a door is a
chair here (wanderers included: they are the people of a run).

Definitions (the same in ``docs/report.md``):

* speed is the distance the centre of movement covered between two committed states over the
  simulation time between them; acceleration and jerk are its differences over time, signed
  along the heading (a chair that brakes decelerates);
* path length is the sum of those distances; mean speed is path length over the time it moved
  (ticks faster than :data:`STOP_MPS`);
* clearance is the distance from the chair's body to the nearest wall (obstacles, doors and the
  lab's border included) and to the nearest other chair's body, each tick;
* a collision is a tick on which its collided flag rises; a near miss is an episode with some
  clearance under ``near_m`` without contact (it ends when every clearance is back over
  1.5 x ``near_m``, as ``iwz incidents`` counts them);
* a watchdog stop is a ``watchdog`` event naming it;
* time waiting at doors is the time it stood still (under :data:`STOP_MPS`) within
  :data:`DOOR_NEAR_M` of a door's body;
* time to goal is from its first committed state to the first one within the goal's radius (a
  goal comes from ``--goal`` or the scenario's ``[[criteria.reach]]`` the launcher writes into
  the recording); time to stop is to the last tick it moved.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Annotated

import msgspec
import numpy as np
import numpy.typing as npt
import shapely

from iw_zenoh.convert import lab_from_msg, spec_from_msg
from iw_zenoh.core.geometry import body_outline, to_world
from iw_zenoh.core.lab import Scene
from iw_zenoh.core.spec import BodyShape, RobotSpec, RobotType
from iw_zenoh.messages import Event, EventKind, WorldInfo, WorldState
from iw_zenoh.record.drive_metrics import DriveFigures, DriveMeter

__all__ = [
    "DOOR_NEAR_M",
    "STOP_MPS",
    "ChairReport",
    "Goal",
    "RunMeter",
    "RunReport",
    "Series",
    "goals_json",
    "parse_goals",
    "recorded_goals",
    "speeds",
]

FloatArray = npt.NDArray[np.float64]

STOP_MPS = 0.02  # slower than this, a chair stands still (odometry noise and creeping excluded)
DOOR_NEAR_M = 1.5  # a chair standing this close to a door's body is waiting at it
NEAR_HYSTERESIS = 1.5  # a near miss ends when every clearance is past 1.5 x the threshold
NO_CLEARANCE = math.inf  # nothing to be near (no walls, or no other chair)


@dataclass(frozen=True)
class Goal:
    """Where a chair should get to: within ``within_m`` of (``x``, ``y``)."""

    x: float
    y: float
    within_m: float = 0.5


class RecordedGoal(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One goal as a recording's ``goals`` metadata holds it (a JSON array of these): robot
    ``robot`` should get within ``within_m`` of (``x_m``, ``y_m``)."""

    robot: Annotated[int, msgspec.Meta(ge=0)]
    x_m: float
    y_m: float
    within_m: Annotated[float, msgspec.Meta(gt=0)] = 0.5


def goals_json(goals: dict[int, Goal]) -> str:
    """The goals as a recording's ``goals`` metadata writes them: a JSON array of :class:`RecordedGoal`."""
    recorded = [RecordedGoal(robot=rid, x_m=g.x, y_m=g.y, within_m=g.within_m) for rid, g in goals.items()]
    return msgspec.json.encode(recorded).decode()


def recorded_goals(text: str) -> dict[int, Goal]:
    """The goals of a recording's ``goals`` metadata: the JSON array written now, or the
    ``ID=X,Y,WITHIN;...`` text that recordings made before carry (:func:`parse_goals`).

    Raises:
        ValueError: Naming what is wrong with the goals.
    """
    if not text.lstrip().startswith("["):
        return parse_goals(text)
    try:
        recorded = msgspec.json.decode(text, type=list[RecordedGoal])
    except msgspec.MsgspecError as e:
        raise ValueError(f"the recorded goals are not a JSON array of {{robot, x_m, y_m, within_m}}: {e}") from None
    if not all(math.isfinite(v) for g in recorded for v in (g.x_m, g.y_m, g.within_m)):
        raise ValueError("the recorded goals hold a number that is not finite")
    return {g.robot: Goal(g.x_m, g.y_m, g.within_m) for g in recorded}


def parse_goals(text: str) -> dict[int, Goal]:
    """Goals written ``ID=X,Y[,WITHIN];ID=X,Y...`` (what ``--goal`` and the recording's metadata carry).

    Args:
        text: The goals, ``;``-separated (empty: none).

    Returns:
        Each robot id's goal.

    Raises:
        ValueError: Naming the goal that is not ``ID=X,Y[,WITHIN]`` with finite numbers.
    """
    out: dict[int, Goal] = {}
    for item in filter(None, (t.strip() for t in text.split(";"))):
        rid, _, xy = item.partition("=")
        try:
            nums = [float(v) for v in xy.split(",")]
            robot = int(rid)
        except ValueError:
            nums, robot = [], -1
        if robot < 0 or len(nums) not in (2, 3) or not all(map(math.isfinite, nums)) or min(nums[2:], default=1) <= 0:
            raise ValueError(f"goal {item!r} is not ID=X,Y[,WITHIN] (e.g. 1=20,6.1,0.5)")
        out[robot] = Goal(*nums)
    return out


@dataclass
class Series:
    """One chair's time series, one value per committed state it was in (for plots)."""

    t_s: list[float] = field(default_factory=list)
    x: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)
    heading: list[float] = field(default_factory=list)
    collided: list[bool] = field(default_factory=list)
    wall_m: list[float] = field(default_factory=list)
    people_m: list[float] = field(default_factory=list)
    door_m: list[float] = field(default_factory=list)


@dataclass(frozen=True)
class ChairReport:
    """What a study measures of one chair (``None``: not measured, e.g. no goal)."""

    robot_id: int
    name: str
    time_in_run_s: float
    time_to_goal_s: float | None
    time_to_stop_s: float | None
    path_length_m: float
    min_clearance_walls_m: float | None
    min_clearance_people_m: float | None
    collisions: int
    near_misses: int
    watchdog_stops: int
    mean_speed_mps: float
    peak_speed_mps: float
    mean_abs_accel_mps2: float
    peak_accel_mps2: float
    rms_jerk_mps3: float
    peak_jerk_mps3: float
    door_wait_s: float
    # a chair a person drove (docs/driving.md; None: not driven by hand)
    driver_inputs: int | None = None
    commands_given: int | None = None
    assist_intervened_s: float | None = None


@dataclass(frozen=True)
class RunReport:
    """A whole run: its chairs and the figures over all of them."""

    duration_s: float
    ticks: int
    chairs: list[ChairReport]
    run: dict[str, float | int | None]
    series: dict[int, Series] = field(default_factory=dict, compare=False, repr=False)
    walls: list[list[tuple[float, float]]] = field(default_factory=list, compare=False, repr=False)


class RunMeter:
    """Follows a run message by message (world descriptions, states, events, in recorded order).

    Args:
        goals: Each chair's goal, by robot id.
        near_m: Clearance under which a near miss is counted.
    """

    def __init__(self, goals: dict[int, Goal] | None = None, *, near_m: float = 0.2) -> None:
        self.goals = dict(goals or {})
        self.near_m = near_m
        self.specs: dict[int, RobotSpec] = {}
        self.scene: Scene | None = None
        self.walls: shapely.Geometry | None = None
        self.series: dict[int, Series] = {}
        self.watchdog: dict[int, int] = {}
        self.near: dict[int, int] = {}
        self._near_now: set[int] = set()
        self.ticks = 0
        self._t0: int | None = None
        self._t_last = 0
        self.drive = DriveMeter()  # a person's driving: on_input and on_state of the drive channels

    def on_info(self, info: WorldInfo) -> None:
        """A world description: the lab, its obstacles and the robots' specs."""
        for s in info.robots:
            self.specs[s.id] = spec_from_msg(s)
        lab = lab_from_msg(info.lab)
        boxes = [shapely.box(o.x0, o.y0, o.x1, o.y1) for o in info.obstacles]
        self.scene = Scene(lab)
        self.walls = shapely.union_all([*self.scene.wall_polygons, self.scene.border, *boxes])

    def on_event(self, ev: Event) -> None:
        """Counts watchdog stops."""
        if ev.kind == EventKind.WATCHDOG and ev.robot_id >= 0:
            self.watchdog[ev.robot_id] = self.watchdog.get(ev.robot_id, 0) + 1

    def on_state(self, st: WorldState) -> None:
        """One committed tick: every chair's pose, clearances and near misses."""
        if self.walls is None or self._t0 is not None and st.sim_time_ns <= self._t_last:
            return  # nothing to measure against yet, or a state seen again (a restarted world)
        known = [k for k, rid in enumerate(st.ids) if rid in self.specs]
        if not known:
            return
        self._t0 = st.sim_time_ns if self._t0 is None else self._t0
        self._t_last = st.sim_time_ns
        self.ticks += 1
        ids = [st.ids[k] for k in known]
        specs = [self.specs[i] for i in ids]
        pose = np.asarray([(st.x[k], st.y[k], st.heading[k]) for k in known], dtype=np.float64)
        polys = _bodies(specs, pose)
        door = np.asarray([s.type == RobotType.DOOR for s in specs])
        wall_d = shapely.distance(polys, self.walls)
        door_d = _nearest(polys, polys[door]) if door.any() else None
        if door_d is not None:
            wall_d = np.minimum(wall_d, np.where(door, NO_CLEARANCE, door_d))
        people_d = _nearest(polys, polys[~door], exclusive=True)
        t_s = (st.sim_time_ns - self._t0) / 1e9
        for k, rid in enumerate(ids):
            if door[k]:
                continue
            s = self.series.setdefault(rid, Series())
            for name, v in (("t_s", t_s), ("x", pose[k, 0]), ("y", pose[k, 1]), ("heading", pose[k, 2])):
                getattr(s, name).append(float(v))
            s.collided.append(bool(st.collided[known[k]]))
            s.wall_m.append(float(wall_d[k]))
            s.people_m.append(float(people_d[k]))
            s.door_m.append(float(door_d[k]) if door_d is not None else NO_CLEARANCE)
            self._near_miss(rid, min(s.wall_m[-1], s.people_m[-1]), s.collided[-1])

    def _near_miss(self, rid: int, gap: float, collided: bool) -> None:
        """Counts a near miss when a gap opens under the threshold without contact."""
        if rid in self._near_now:
            if gap > self.near_m * NEAR_HYSTERESIS:
                self._near_now.discard(rid)
        elif gap < self.near_m and not collided and gap > 0.0:
            self._near_now.add(rid)
            self.near[rid] = self.near.get(rid, 0) + 1

    def finish(self) -> RunReport:
        """The report of everything seen so far."""
        chairs = [self._chair(rid, s) for rid, s in sorted(self.series.items())]
        walls = [list(w.corners) for w in self.scene.lab.walls] if self.scene is not None else []
        duration = (self._t_last - self._t0) / 1e9 if self._t0 is not None else 0.0
        return RunReport(duration, self.ticks, chairs, _run_figures(chairs), dict(self.series), walls)

    def _chair(self, rid: int, s: Series) -> ChairReport:
        k = _kinematics(s)
        goal = self.goals.get(rid)
        t_goal = None
        if goal is not None:
            near = np.hypot(np.asarray(s.x) - goal.x, np.asarray(s.y) - goal.y) <= goal.within_m
            t_goal = float(s.t_s[int(np.argmax(near))] - s.t_s[0]) if near.any() else None
        rises = sum(1 for a, b in zip([False, *s.collided], s.collided, strict=False) if b and not a)
        waiting = (k.v < STOP_MPS) & (np.asarray(s.door_m[1:]) <= DOOR_NEAR_M)
        return ChairReport(
            robot_id=rid,
            name=self.specs[rid].name,
            time_in_run_s=s.t_s[-1] - s.t_s[0],
            time_to_goal_s=t_goal,
            time_to_stop_s=k.t_stop,
            path_length_m=k.path_m,
            min_clearance_walls_m=_finite_min(s.wall_m),
            min_clearance_people_m=_finite_min(s.people_m),
            collisions=rises,
            near_misses=self.near.get(rid, 0),
            watchdog_stops=self.watchdog.get(rid, 0),
            mean_speed_mps=k.mean_v,
            peak_speed_mps=_peak(k.v),
            mean_abs_accel_mps2=float(np.mean(np.abs(k.a))) if len(k.a) else 0.0,
            peak_accel_mps2=_peak(k.a),
            rms_jerk_mps3=float(np.sqrt(np.mean(k.j**2))) if len(k.j) else 0.0,
            peak_jerk_mps3=_peak(k.j),
            door_wait_s=float(np.sum(k.dt[waiting])),
            **_driving(self.drive.figures(rid)),  # type: ignore[arg-type]
        )


def _driving(f: DriveFigures | None) -> dict[str, float | int]:
    """A chair's driving figures as ChairReport fields (none when nobody drove it)."""
    if f is None:
        return {}
    return {"driver_inputs": f.inputs, "commands_given": f.commands, "assist_intervened_s": f.intervened_s}


def _nearest(polys: npt.NDArray[np.object_], others: npt.NDArray[np.object_], *, exclusive: bool = False) -> FloatArray:
    """(N,) each body's distance to the nearest of ``others`` (an R-tree: not N x M distances);
    ``exclusive``: not to itself (``others`` a subset of ``polys``); inf when there is none."""
    out = np.full(len(polys), NO_CLEARANCE)
    if len(others) == 0:
        return out
    (i, _), d = shapely.STRtree(others).query_nearest(polys, return_distance=True, exclusive=exclusive)
    np.minimum.at(out, i, d)
    return out


def _bodies(specs: list[RobotSpec], pose: FloatArray) -> npt.NDArray[np.object_]:
    """Each robot's body at its pose, as shapely polygons."""
    w = np.asarray([s.width_m for s in specs])
    h = np.asarray([s.height_m for s in specs])
    com = np.asarray([s.com for s in specs])
    circle = np.asarray([s.shape == BodyShape.CIRCLE for s in specs])
    outline = to_world(body_outline(w, h, com, circle), pose[:, 0], pose[:, 1], pose[:, 2])
    return np.asarray(shapely.polygons(outline), dtype=object)


@dataclass(frozen=True)
class _Kinematics:
    """A chair's motion between its committed states (arrays one per interval, or fewer)."""

    dt: FloatArray  # interval lengths, s
    v: FloatArray  # speed over each interval, m/s
    a: FloatArray  # acceleration between neighbouring intervals, m/s2 (signed along the heading)
    j: FloatArray  # jerk, m/s3
    path_m: float
    mean_v: float  # path over the time it moved
    t_stop: float | None  # from its first state to the end of the last interval it moved in


def _kinematics(s: Series) -> _Kinematics:
    """Speeds (per interval), accelerations, jerks, path length, mean speed, time to stop."""
    t = np.asarray(s.t_s)
    x, y, th = np.asarray(s.x), np.asarray(s.y), np.asarray(s.heading)
    dt = np.diff(t)
    step = np.hypot(np.diff(x), np.diff(y))
    ok = dt > 0
    v = np.where(ok, step / np.where(ok, dt, 1.0), 0.0)
    along = np.sign(np.diff(x) * np.cos(th[:-1]) + np.diff(y) * np.sin(th[:-1]))
    sv = v * np.where(along == 0, 1.0, along)  # signed along the heading
    mid = 0.5 * (t[1:] + t[:-1])  # each speed holds at the middle of its interval
    a = np.diff(sv) / np.diff(mid) if len(sv) > 1 else np.zeros(0)
    am = 0.5 * (mid[1:] + mid[:-1])
    j = np.diff(a) / np.diff(am) if len(a) > 1 else np.zeros(0)
    moving = v >= STOP_MPS
    path = float(step.sum())
    return _Kinematics(
        dt=dt,
        v=v,
        a=a,
        j=j,
        path_m=path,
        mean_v=path / float(dt[moving].sum()) if moving.any() else 0.0,
        t_stop=float(t[1:][moving][-1] - t[0]) if moving.any() else None,
    )


def speeds(s: Series) -> tuple[FloatArray, FloatArray]:
    """A chair's speed over time: (mid-times of its intervals in s, speeds in m/s), for plots."""
    t = np.asarray(s.t_s)
    return 0.5 * (t[1:] + t[:-1]), _kinematics(s).v


def _peak(a: FloatArray) -> float:
    return float(np.max(np.abs(a))) if a.size else 0.0


def _finite_min(values: list[float]) -> float | None:
    m = min(values, default=NO_CLEARANCE)
    return m if math.isfinite(m) else None


def _run_figures(chairs: list[ChairReport]) -> dict[str, float | int | None]:
    """The run's figures over its chairs: totals, the worst and the slowest."""

    def worst(name: str, *, lowest: bool) -> float | None:
        vals = [float(v) for c in chairs if (v := getattr(c, name)) is not None]
        if not vals:
            return None
        return min(vals) if lowest else max(vals)

    reached = [c.time_to_goal_s for c in chairs if c.time_to_goal_s is not None]
    return {
        "chairs": len(chairs),
        "goals_reached": len(reached),
        "time_to_last_goal_s": max(reached) if reached else None,
        "path_length_m": sum(c.path_length_m for c in chairs),
        "min_clearance_walls_m": worst("min_clearance_walls_m", lowest=True),
        "min_clearance_people_m": worst("min_clearance_people_m", lowest=True),
        "collisions": sum(c.collisions for c in chairs),
        "near_misses": sum(c.near_misses for c in chairs),
        "watchdog_stops": sum(c.watchdog_stops for c in chairs),
        "mean_speed_mps": float(np.mean([c.mean_speed_mps for c in chairs])) if chairs else None,
        "peak_speed_mps": worst("peak_speed_mps", lowest=False),
        "peak_accel_mps2": worst("peak_accel_mps2", lowest=False),
        "rms_jerk_mps3": float(np.sqrt(np.mean([c.rms_jerk_mps3**2 for c in chairs]))) if chairs else None,
        "door_wait_s": sum(c.door_wait_s for c in chairs),
    }
