"""A person's stick turned into a chair's (v, w), and shared control: pure, no clock.

* :func:`stick_twist`: a proportional joystick as a power wheelchair's: a dead zone, speed levels
  (level k of 5 allows k/5 of the chair's top speed), half speed backwards.
* :func:`ramp`: the chair's comfort acceleration (speeding up and turning faster are limited;
  slowing down is limited to twice that, and shared control may stop at once).
* :class:`SharedControl`: the levels of docs/driving.md.

  - ``off``: the command as given.
  - ``safe`` (the seed's "simple shared control": the user's control never takes the chair into
    danger): the chair never drives into what its own sensors see. Every reading is a set of
    points across its cone (a wide sonar could have seen its thing anywhere in it); the chair's
    outline, grown by a margin, is swept along the arc of the command, and the speed is limited
    so that the chair stops, through its own motor model (the command applies next tick, then
    the motors' filter ``out = (1 - curve) * cmd + curve * out``) and a tick of lateness, before
    the first place where the outline would come within the margin of a point. A move that
    takes the chair away from what it is already too near is allowed.
  - ``assist``: steers round obstacles and through doorways, keeping the driver's direction. A
    sampling blend in the family of the dynamic window approach (Fox, Burgard and Thrun, "The
    dynamic window approach to collision avoidance", IEEE Robotics & Automation Magazine 4(1),
    1997), whose candidates are the driver's own way shifted sideways (0.1 m apart, up to
    0.8 m, smoothly over SHIFT_OVER_M) rather than other arcs: the candidate that maximises
    ``min(free, horizon) / horizon - WEIGHT * |shift| / 0.8 m`` (free: the path length before the
    grown outline meets a point) is followed by pure pursuit (Coulter, "Implementation of the
    pure pursuit path tracking algorithm", CMU-RI-TR-92-01, 1992) to a point LOOK_AHEAD_M along
    it, at the driver's speed; then limited as ``safe``. A driver's way free to the horizon is
    driven as given (no intervention); backwards and on the spot, ``assist`` is ``safe``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from iw_zenoh.core.spec import RobotSpec

__all__ = [
    "Assisted",
    "DriveLimits",
    "SharedControl",
    "free_path",
    "ramp",
    "seen_points",
    "stick_twist",
]

FloatArray = npt.NDArray[np.float64]

DEAD_ZONE = 0.1  # a stick within this of its centre is centred (a real stick rarely rests at 0)
BACK_FRACTION = 0.5  # backwards at most half the forward speed (as power chairs do)
TURN_RADIUS_M = 0.5  # at full stick sideways the chair turns as fast as its top speed on this radius
CONE_STEP_RAD = math.radians(5.0)  # a cone's reading stands for points this far apart across it
PATH_STEP_M = 0.02  # the outline is checked along the arc this often
TURN_STEP_RAD = math.radians(2.0)  # and, turning on the spot, this often
HORIZON_M = 2.0  # an arc free this far is free
TURN_HORIZON_RAD = math.pi / 2
MARGIN_M = 0.08  # keep this clear of every point seen (a reading's noise, the cones' corners)
WEIGHT = 0.3  # assist: cost of the largest sideways shift, against a free path to the horizon
SHIFTS = np.linspace(-0.8, 0.8, 17)  # assist: sideways shifts of the driver's way tried, m (0.1 m apart)
SHIFT_OVER_M = 1.2  # a shift is made over this much of the way
LOOK_AHEAD_M = 0.6  # assist steers towards the point this far along the chosen way
SAME = 1e-6  # a command changed by less than this is unchanged


@dataclass(frozen=True)
class DriveLimits:
    """How a chair may be driven by hand.

    Attributes:
        max_speed_mps: Its top speed (the spec's).
        max_turn_radps: Its top turn rate at full stick sideways.
        accel_mps2: Comfort acceleration.
        turn_accel_radps2: Comfort turn acceleration.
        levels: Speed levels.
        dead_zone: Stick dead zone.
    """

    max_speed_mps: float
    max_turn_radps: float
    accel_mps2: float = 0.6
    turn_accel_radps2: float = 2.0
    levels: int = 5
    dead_zone: float = DEAD_ZONE

    @classmethod
    def of(cls, spec: RobotSpec, **kw: float) -> DriveLimits:
        """A chair's limits from its spec: top speed, and a turn rate its wheels reach."""
        reach = 2.0 * spec.max_speed_mps / spec.height_m  # both wheels at full, opposite
        return cls(spec.max_speed_mps, min(reach, spec.max_speed_mps / TURN_RADIUS_M), **kw)  # type: ignore[arg-type]


def stick_twist(x: float, y: float, level: int, lim: DriveLimits) -> tuple[float, float]:
    """A proportional stick to (v m/s, w rad/s counter-clockwise).

    Args:
        x: Stick right, -1..1.
        y: Stick forward, -1..1.
        level: Speed level, 1..lim.levels.
        lim: The chair's limits.

    Returns:
        ``(v, w)``: zero within the dead zone; beyond it proportional to the stick's travel past
        the dead zone, times ``level / levels`` of the top speed and turn rate.
    """
    if not (math.isfinite(x) and math.isfinite(y)):
        return 0.0, 0.0
    x, y = max(-1.0, min(1.0, x)), max(-1.0, min(1.0, y))
    r = math.hypot(x, y)
    if r <= lim.dead_zone:
        return 0.0, 0.0
    k = (min(r, 1.0) - lim.dead_zone) / (1.0 - lim.dead_zone) / r
    f = max(1, min(lim.levels, level)) / lim.levels
    v = y * k * lim.max_speed_mps * f
    if v < 0.0:
        v *= BACK_FRACTION
    return v, -x * k * lim.max_turn_radps * f


def ramp(prev: tuple[float, float], want: tuple[float, float], dt_s: float, lim: DriveLimits) -> tuple[float, float]:
    """``want`` reached from ``prev`` at the chair's comfort acceleration (slowing at twice it)."""

    def one(a: float, b: float, rate: float) -> float:
        step = rate * dt_s * (2.0 if abs(b) < abs(a) or a * b < 0 else 1.0)
        return a + max(-step, min(step, b - a))

    return one(prev[0], want[0], lim.accel_mps2), one(prev[1], want[1], lim.turn_accel_radps2)


def seen_points(spec: RobotSpec, ids: list[int], dists: list[float | None]) -> FloatArray:
    """What a reading saw, as points in the chair's frame (origin at its centre of movement).

    A cone's reading d is a set of points at d from the sensor across its whole aperture, one
    every CONE_STEP_RAD (the thing may be anywhere in it). Returns shape (M, 2).
    """
    by_id = {s.id: s for s in spec.sensors}
    out: list[FloatArray] = []
    for i, d in zip(ids, dists, strict=True):
        s = by_id.get(i)
        if s is None or d is None or not math.isfinite(d):
            continue
        half = math.radians(s.cone_deg) / 2
        n = max(2, math.ceil(2 * half / CONE_STEP_RAD) + 1)
        a = math.radians(s.angle_deg) + np.linspace(-half, half, n)
        out.append(np.stack([s.x_m + d * np.cos(a), s.y_m + d * np.sin(a)], axis=1))
    return np.concatenate(out) if out else np.zeros((0, 2))


def _clearance(points: FloatArray, poses: FloatArray, box: tuple[float, float, float]) -> FloatArray:
    """Distance from the outline (front, rear, half width) at each pose (K, 3) to the nearest point: (K,)."""
    if len(points) == 0:
        return np.full(len(poses), math.inf)
    front, rear, half = box
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    dx, dy = points[None, :, 0] - poses[:, 0:1], points[None, :, 1] - poses[:, 1:2]
    px, py = c * dx + s * dy, -s * dx + c * dy
    ex = np.maximum(np.maximum(rear - px, px - front), 0.0)
    ey = np.maximum(np.abs(py) - half, 0.0)
    return np.asarray(np.hypot(ex, ey).min(axis=1), dtype=np.float64)


def _arc(v: float, w: float) -> tuple[FloatArray, float, float]:
    """Poses (K, 3) along the arc of (v, w) from the chair (its frame), the step between them
    and the horizon (metres; radians when it turns on the spot)."""
    if abs(v) > SAME:
        s = np.arange(PATH_STEP_M, HORIZON_M + PATH_STEP_M / 2, PATH_STEP_M) * math.copysign(1.0, v)
        k = w / v
        th = k * s
        if abs(k) < 1e-9:
            xs, ys = s, np.zeros_like(s)
        else:
            xs, ys = np.sin(th) / k, (1.0 - np.cos(th)) / k
        return np.stack([xs, ys, th], axis=1), PATH_STEP_M, HORIZON_M
    th = np.arange(TURN_STEP_RAD, TURN_HORIZON_RAD + TURN_STEP_RAD / 2, TURN_STEP_RAD) * math.copysign(1.0, w)
    return np.stack([np.zeros_like(th), np.zeros_like(th), th], axis=1), TURN_STEP_RAD, TURN_HORIZON_RAD


def shifted_path(v: float, w: float, shift_m: float) -> FloatArray:
    """Poses (K, 3) along the arc of (v > 0, w) moved sideways by ``shift_m`` (left positive)
    over SHIFT_OVER_M, smoothly (half a cosine), then along it: the way round an obstacle or
    into a doorway that keeps the driver's direction."""
    base, _, _ = _arc(v, w)
    s = np.arange(1, len(base) + 1) * PATH_STEP_M
    u = np.minimum(s / SHIFT_OVER_M, 1.0)
    off = shift_m * 0.5 * (1.0 - np.cos(np.pi * u))
    slope = np.where(u < 1.0, shift_m * 0.5 * np.pi / SHIFT_OVER_M * np.sin(np.pi * u), 0.0)
    th = base[:, 2]
    return np.stack([base[:, 0] - np.sin(th) * off, base[:, 1] + np.cos(th) * off, th + np.arctan(slope)], axis=1)


def _free(
    points: FloatArray, box: tuple[float, float, float], poses: FloatArray, step: float, margin_m: float
) -> float:
    """How far along ``poses`` (one every ``step``) the outline stays clear (see :func:`free_path`)."""
    now = float(_clearance(points, np.zeros((1, 3)), box)[0])
    ahead = _clearance(points, poses, box)
    bad = (ahead < margin_m) & (ahead < now - 1e-3)
    if not bad.any():
        return len(poses) * step
    return float(np.argmax(bad)) * step  # the last sample still clear


def free_path(
    points: FloatArray, box: tuple[float, float, float], v: float, w: float, *, margin_m: float = MARGIN_M
) -> float:
    """How far the chair may go along the arc of (v, w) before its outline comes within
    ``margin_m`` of a point, without getting nearer than it is: metres (radians when it turns on
    the spot); the horizon when nothing is in the way.

    Args:
        points: What was seen, (M, 2) in the chair's frame.
        box: The outline: front (> 0), rear (< 0), half width, from the centre of movement.
        v: Forward speed (its sign and, with ``w``, the arc's curvature).
        w: Turn rate.
        margin_m: Clearance kept.
    """
    if abs(v) <= SAME and abs(w) <= SAME:
        return HORIZON_M
    poses, step, _ = _arc(v, w)
    return _free(points, box, poses, step, margin_m)


@dataclass(frozen=True)
class Assisted:
    """Shared control's answer: the command to drive, whether it changed the driver's, and the
    nearest thing seen (None: nothing)."""

    v_mps: float
    w_radps: float
    intervened: bool
    nearest_m: float | None


class SharedControl:
    """A chair's shared control (see the module doc), with its model of its own motors.

    Args:
        spec: The chair.
        lim: Its hand-driving limits.
        margin_m: Clearance ``safe`` and ``assist`` keep.
    """

    def __init__(self, spec: RobotSpec, lim: DriveLimits, *, margin_m: float = MARGIN_M) -> None:
        self.spec = spec
        self.lim = lim
        self.margin_m = margin_m
        front = spec.com * spec.width_m
        self.box = (front, front - spec.width_m, 0.5 * spec.height_m)
        self.curve = spec.acceleration_curve
        self.motor = (0.0, 0.0)  # the chair's motors' (v, w) now, as its model has them

    def step(
        self, level: str, want: tuple[float, float], points: FloatArray, dt_s: float, nearest_m: float | None
    ) -> Assisted:
        """This tick's command for the driver's ``want`` (v, w) at shared-control ``level``.

        Args:
            level: off, safe or assist.
            want: The driver's command (after the stick's ramp).
            points: What the sensors saw this tick (:func:`seen_points`).
            dt_s: The tick.
            nearest_m: The nearest reading, for the answer.
        """
        v, w = want
        if level == "assist" and abs(v) > SAME:
            v, w = self._blend(points, v, w)
        if level in ("safe", "assist"):
            v, w = self._limited(points, v, w, dt_s)
        c = self.curve  # the motor filter (the command applies from next tick)
        self.motor = ((1.0 - c) * v + c * self.motor[0], (1.0 - c) * w + c * self.motor[1])
        changed = abs(v - want[0]) > SAME or abs(w - want[1]) > SAME
        return Assisted(v, w, changed, nearest_m)

    def _blend(self, points: FloatArray, v: float, w: float) -> tuple[float, float]:
        """The sideways shift of the driver's way that is freest for the least shift, steered
        to by pure pursuit (a look-ahead point on it)."""
        if v <= SAME or free_path(points, self.box, v, w, margin_m=self.margin_m) >= HORIZON_M:
            return v, w
        best: FloatArray | None = None
        best_score = -math.inf
        for shift in SHIFTS:
            path = shifted_path(v, w, float(shift))
            free = _free(points, self.box, path, PATH_STEP_M, self.margin_m)
            score = min(free, HORIZON_M) / HORIZON_M - WEIGHT * abs(float(shift)) / SHIFTS[-1]
            if score > best_score + 1e-9 or (abs(score - best_score) <= 1e-9 and best is not None and shift == 0.0):
                best, best_score = path, score
        assert best is not None
        px, py, _ = best[round(LOOK_AHEAD_M / PATH_STEP_M) - 1]
        k = 2.0 * py / (px * px + py * py)
        return v, max(-self.lim.max_turn_radps, min(self.lim.max_turn_radps, v * k))

    def _limited(self, points: FloatArray, v: float, w: float, dt_s: float) -> tuple[float, float]:
        """The command scaled down (its arc kept) so the chair stops within the free path."""
        if abs(v) <= SAME and abs(w) <= SAME:
            return 0.0, 0.0
        free = free_path(points, self.box, v, w, margin_m=self.margin_m)
        c = self.curve
        # commanding u now then zero: the motors reach u1 = (1-c) u + c now, then decay by c a
        # tick; with a tick of lateness the chair covers dt * u1 * (1/(1-c) + 1) after this tick
        turning = abs(v) <= SAME
        now = abs(self.motor[1] if turning else self.motor[0])
        u1_max = free / (dt_s * (1.0 / (1.0 - c) + 1.0)) if c < 1.0 else 0.0
        u_max = max(0.0, (u1_max - c * now) / (1.0 - c)) if c < 1.0 else 0.0
        want = abs(w) if turning else abs(v)
        if want <= u_max:
            return v, w
        f = u_max / want
        return v * f, w * f
