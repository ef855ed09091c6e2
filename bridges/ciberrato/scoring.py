"""Ciber-Rato's robot state machine and scores (fact sheet sections 7.8 to 7.10), pure.

One :class:`RobotGame` per legacy robot. The bridge feeds it each committed step
(:class:`StepInput`) and shows what it holds: the state (Stopped, Running, Returning, Finished,
Removed) and the ``<Score>`` fields, in Measures when ScoreSensor is On and to viewers.

Scoring modes (the legacy simulator's ``--scoring``):

* 0, competitive (lower is better): targets visited with the VisitingLed, a return home measured
  by :class:`PathLength` (shortest path of a disc of radius 0.5 from the start);
* 1, control (C1; higher is better): 10 points per cell of the lab's closed loop of 2 m cells,
  :func:`control_loop`, built from the robot's start at its first Running step (whenever it
  registered: the legacy simulator built it only at Time 0);
* 2 and 3, mapping and planning (C2 to C5): the competitive function without the Returning state,
  starting from 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np
import shapely
import shapely.geometry

from iw_zenoh.core.lab import Lab

__all__ = ["FreeSpace", "Mode", "PathLength", "RobotGame", "StepInput", "control_loop", "target_at"]

RADIUS = 0.5  # the legacy robots' disc
CELL = 2.0  # control mode's cells


class Mode(IntEnum):
    """The legacy ``--scoring`` modes."""

    COMPETITIVE = 0
    CONTROL = 1
    MAPPING = 2
    PLANNING = 3


def target_at(lab: Lab, x: float, y: float) -> int:
    """The first target the whole disc is inside (distance <= radius - 0.5), or -1 (the scoring
    code's helper; the Ground sensor reports the last one instead)."""
    for i, t in enumerate(lab.targets):
        if math.hypot(x - t.x, y - t.y) <= t.radius_m - RADIUS:
            return i
    return -1


class FreeSpace:
    """Where the centre of a disc of radius 0.5 may go in a lab, as a visibility graph.

    Walls grown by the radius with round corners and the border shrunk by it; the graph's nodes
    are the free space's reflex corners (the only places a shortest path bends), its edges the
    pairs that see each other. The round corners are polygons of ``quad_segs`` sides a quarter
    circle, so path lengths are within a few tenths of a percent of the legacy ``cbgraph``'s arcs.
    Built once per lab (a fraction of a second for a Ciber-Rato lab).
    """

    def __init__(self, lab: Lab, *, quad_segs: int = 3) -> None:
        r = RADIUS
        inner = shapely.box(r, r, lab.width_m - r, lab.height_m - r)
        walls = [shapely.Polygon(w.corners) for w in lab.walls]
        grown = shapely.union_all(shapely.buffer(walls, r, quad_segs=quad_segs)) if walls else shapely.Polygon()
        free = inner.difference(grown)
        # segments are checked against the free space widened by a hair, so one running along
        # a boundary (or ending on a corner) counts as free
        self._free = shapely.buffer(free, 1e-6)
        shapely.prepare(self._free)
        pts: list[np.ndarray] = []
        for poly in getattr(free, "geoms", [free]):
            if poly.is_empty:
                continue
            poly = shapely.geometry.polygon.orient(poly, 1.0)  # the free side on the left of every ring
            for ring in (poly.exterior, *poly.interiors):
                c = np.asarray(ring.coords)[:-1]
                a, b = np.roll(c, 1, axis=0), np.roll(c, -1, axis=0)
                turn = (c[:, 0] - a[:, 0]) * (b[:, 1] - c[:, 1]) - (c[:, 1] - a[:, 1]) * (b[:, 0] - c[:, 0])
                pts.append(c[turn < 0])  # a right turn: a reflex corner of the free space
        self.nodes = np.concatenate(pts) if pts else np.zeros((0, 2))
        n = len(self.nodes)
        i, j = np.triu_indices(n, 1)
        see = np.zeros((n, n), dtype=bool)
        if len(i):
            ok = shapely.covered_by(shapely.linestrings(np.stack([self.nodes[i], self.nodes[j]], axis=1)), self._free)
            see[i, j] = see[j, i] = ok
        self.edges = np.where(
            see, np.hypot(*(self.nodes[:, None, :] - self.nodes[None, :, :]).transpose(2, 0, 1)), np.inf
        )

    def visible(self, p: tuple[float, float], targets: np.ndarray) -> np.ndarray:
        """Which of ``targets`` (K, 2) the point ``p`` sees through free space."""
        if len(targets) == 0:
            return np.zeros(0, dtype=bool)
        lines = shapely.linestrings(
            np.stack([np.broadcast_to(np.asarray(p, dtype=np.float64), targets.shape), targets], axis=1)
        )
        return np.asarray(shapely.covered_by(lines, self._free), dtype=bool)


class PathLength:
    """``D(p)``: the shortest path length of a disc of radius 0.5 from ``start`` to ``p``.

    Args:
        lab: The lab.
        start: The start point (a robot's grid position).
        space: The lab's :class:`FreeSpace`, when already built (one per lab serves every robot).
    """

    def __init__(self, lab: Lab, start: tuple[float, float], *, space: FreeSpace | None = None) -> None:
        self.space = space or FreeSpace(lab)
        self.start = (float(start[0]), float(start[1]))
        nodes = self.space.nodes
        n = len(nodes)
        dist = np.full(n, np.inf)
        seen = self.space.visible(self.start, nodes)
        dist[seen] = np.hypot(nodes[seen, 0] - self.start[0], nodes[seen, 1] - self.start[1])
        done = np.zeros(n, dtype=bool)
        for _ in range(n):  # Dijkstra on the dense graph
            left = np.where(done, np.inf, dist)
            k = int(np.argmin(left)) if n else 0
            if n == 0 or not np.isfinite(left[k]):
                break
            done[k] = True
            dist = np.minimum(dist, dist[k] + self.space.edges[k])
        self._dist = dist

    def __call__(self, x: float, y: float) -> float:
        """``D((x, y))``; ``inf`` when no path reaches it (a point inside a grown wall)."""
        sp = self.space
        direct = sp.visible(self.start, np.asarray([[x, y]], dtype=np.float64))[0]
        best = math.dist(self.start, (x, y)) if direct else math.inf
        vis = sp.visible((x, y), sp.nodes)
        if vis.any():
            via = self._dist[vis] + np.hypot(sp.nodes[vis, 0] - x, sp.nodes[vis, 1] - y)
            best = min(best, float(via.min()))
        return best


def control_loop(lab: Lab, x: float, y: float) -> list[tuple[int, int]] | None:
    """Control mode's closed loop of 2 m cells from the robot's cell, or None ("Lab has no Loop!").

    The first move is east, whatever is there (the legacy simulator's loop starts with the cell
    east of the start); then at each cell it tries right, straight, then left of the current
    direction, a move being allowed when the straight line between the two cell centres hits no
    wall (nor leaves the lab); it ends back at the start cell.
    """
    walls = [shapely.Polygon(w.corners) for w in lab.walls]
    solid = shapely.union_all(walls) if walls else shapely.Polygon()
    shapely.prepare(solid)
    cols, rows = int(lab.width_m // CELL), int(lab.height_m // CELL)
    start = (int(x // CELL), int(y // CELL))

    def centre(c: tuple[int, int]) -> tuple[float, float]:
        return (c[0] * CELL + CELL / 2, c[1] * CELL + CELL / 2)

    def free(a: tuple[int, int], b: tuple[int, int]) -> bool:
        if not (0 <= b[0] < cols and 0 <= b[1] < rows):
            return False
        return not shapely.intersects(shapely.LineString([centre(a), centre(b)]), solid)

    cell, d = (start[0] + 1, start[1]), (1, 0)
    loop = [start]
    for _ in range(4 * cols * rows + 4):
        loop.append(cell)
        for nd in ((d[1], -d[0]), d, (-d[1], d[0])):  # right, straight, left
            nxt = (cell[0] + nd[0], cell[1] + nd[1])
            if free(cell, nxt):
                cell, d = nxt, nd
                break
        else:
            return None
        if cell == start:
            return loop
    return None


@dataclass(frozen=True)
class StepInput:
    """What one committed step tells a robot's game.

    Attributes:
        now: ``Time`` after the step (Running steps so far).
        running: Whether the simulator ran this step.
        x: The robot's centre.
        y: The robot's centre.
        collision: A collision flag this step.
        hit_wall: It hit a wall.
        hit_robot: It hit a robot.
        end_led: The EndLed as the simulator holds it.
        returning_led: The ReturningLed.
        visiting_led: The VisitingLed.
        returning_now: A ``ReturningLed="On"`` action arrived this cycle.
        removed: Removal was asked.
    """

    now: int
    running: bool
    x: float
    y: float
    collision: bool = False
    hit_wall: bool = False
    hit_robot: bool = False
    end_led: bool = False
    returning_led: bool = False
    visiting_led: bool = False
    returning_now: bool = False
    removed: bool = False


@dataclass
class RobotGame:
    """One legacy robot's state and score.

    Args:
        lab: The lab (its targets).
        mode: The scoring mode.
        sim_time: ``SimTime`` (0: no end).
        wall_penalty: ``CollisionWallPenalty``.
        robot_penalty: ``CollisionRobotPenalty``.
        start: The robot's start (grid) position.
        path: ``D(p)`` from the start (competitive mode; built on first use when None).
    """

    lab: Lab
    mode: Mode = Mode.COMPETITIVE
    sim_time: int = 0
    wall_penalty: int = 2
    robot_penalty: int = 2
    start: tuple[float, float] = (0.0, 0.0)
    path: PathLength | None = None
    state: str = "Stopped"
    remembered: str = "Running"
    pen: int = 0
    score: int = 0
    score_control: int = 0
    arrival_time: int = 0
    returning_time: int = 0
    start_returning_time: int = 0
    dist_at_arrival: float = 0.0
    collisions: int = 0
    collision: bool = False
    visited: list[bool] = field(default_factory=list)
    loop: list[tuple[int, int]] | None = None
    loop_index: int = 1
    _was_colliding: bool = False
    _loop_done: bool = False

    def __post_init__(self) -> None:
        self.visited = [False] * len(self.lab.targets)
        if self.mode == Mode.COMPETITIVE:
            self.pen = 100 + 100 * len(self.lab.targets)
        self.score = self.pen

    @property
    def visited_mask(self) -> str:
        """One ``0``/``1`` per target, in lab order."""
        return "".join("1" if v else "0" for v in self.visited)

    @property
    def finished(self) -> bool:
        """A Finished robot never moves again."""
        return self.state == "Finished"

    def _d(self, x: float, y: float) -> float:
        if self.path is None:
            self.path = PathLength(self.lab, self.start)
        return self.path(x, y)

    def _ratio(self, x: float, y: float) -> int:
        d = self._d(x, y)
        if not math.isfinite(d) or self.dist_at_arrival <= 0:
            return 100
        return math.floor(100 * d / self.dist_at_arrival)

    def step(self, s: StepInput) -> None:
        """Scores (Running steps, not Removed or Finished), then the state machine."""
        self.collision = s.collision
        if s.running and self.state not in ("Removed", "Finished"):
            self._score(s)
        self._transition(s)

    def _score(self, s: StepInput) -> None:
        rising = s.collision and not self._was_colliding
        self._was_colliding = s.collision
        if rising:
            self.collisions += 1
            penalty = (self.wall_penalty if s.hit_wall else 0) + (self.robot_penalty if s.hit_robot else 0)
            self.pen += -penalty if self.mode == Mode.CONTROL else penalty
        if self.mode == Mode.CONTROL:
            self._score_control(s)
            return
        # where it stands matters only to a lit LED (this runs for every robot every step)
        leds = s.end_led or s.returning_led or s.visiting_led or s.returning_now
        here = target_at(self.lab, s.x, s.y) if leds else -1
        all_visited = all(self.visited)
        phase = self.remembered if self.state == "Stopped" else self.state
        if phase == "Returning":
            if s.now == self.sim_time and not s.end_led:
                self.pen += 15
            self.returning_time = s.now - self.start_returning_time
            self.score = self.pen + self._ratio(s.x, s.y)
            if s.returning_now and here >= 0 and all_visited:
                self.dist_at_arrival = self._d(s.x, s.y)
                self.start_returning_time = s.now
                self.returning_time = 0
            else:
                self._visiting(s, here)
            return
        self.score = self.pen
        if s.end_led and here >= 0 and all_visited:
            self.dist_at_arrival = self._d(s.x, s.y)
            self.arrival_time = self.start_returning_time = s.now
            self.score = self.pen + self._ratio(s.x, s.y)
        elif s.returning_led and here >= 0 and all_visited:
            self.dist_at_arrival = self._d(s.x, s.y)
            self.start_returning_time = s.now
            self.pen -= 100
            self.score = self.pen + 100
        elif s.visiting_led:
            self._visiting(s, here)
        if not any(self.visited):
            self.arrival_time = s.now

    def _visiting(self, s: StepInput, here: int) -> None:
        if not s.visiting_led:
            return
        if here >= 0 and not self.visited[here]:
            self.visited[here] = True
            self.pen -= 100
        elif here < 0:
            self.pen += 5  # every cycle the LED stays on away from a target
        self.score = 100 + self.pen

    def _score_control(self, s: StepInput) -> None:
        if not self._loop_done:
            # its first Running step, whatever the Time: the legacy simulator builds the loop when
            # its robots first run at Time 0, which a robot registered into a running world (or
            # after a pause) never sees, and it then scored nothing for ever
            self._loop_done = True
            self.loop = control_loop(self.lab, self.start[0], self.start[1])
        if self.loop and len(self.loop) > 1:
            cell = (int(s.x // CELL), int(s.y // CELL))
            if cell == self.loop[self.loop_index]:
                self.score_control += 10
                self.loop_index = (self.loop_index + 1) % len(self.loop)
        self.score = self.pen if s.end_led else self.pen + self.score_control

    def _transition(self, s: StepInput) -> None:
        st = self.state
        if s.removed:
            self.state = "Removed"
        elif st in ("Running", "Returning"):
            if not s.running:
                self.remembered, self.state = st, "Stopped"
            elif s.end_led:
                self.state = "Finished"
            elif st == "Running" and s.returning_led and self.mode == Mode.COMPETITIVE:
                here = target_at(self.lab, s.x, s.y)
                self.state = "Returning" if here >= 0 and all(self.visited) else "Finished"
        elif st == "Stopped" and s.running:
            self.state = self.remembered
