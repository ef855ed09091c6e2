"""The chair's acquisition board, modelled: what ``iwz chair emulate`` runs behind a serial line.

Pure (no clock, no I/O): the caller passes the time. The board drives the seed's motor model and
differential drive (the core, through :class:`~iw_zenoh.agents.emulated.LocalWorld`) in its own
"real" room, which may hold obstacles the simulator's map lacks; counts encoder ticks with slip;
reads its sonars and infrareds there with seeded noise; drains a battery; latches an e-stop; and
keeps its own watchdog: no valid frame for :data:`WATCHDOG_S` and the motors are zeroed.

:func:`chair_spec` is the chair both ends of the link agree on (the LIACC prototype's body with
the autonomous chair's mapping cones), optionally changed by a spec file (``docs/spec.md``).
"""

from __future__ import annotations

import math
from dataclasses import replace

from iw_zenoh.agents.autopilot import mapping_chair
from iw_zenoh.agents.emulated import LocalWorld

from iw_zenoh.core.lab import Lab
from iw_zenoh.core.spec import NoiseSpec, RobotSpec, RobotType
from iw_zenoh.scenario.specfile import SPEC_TABLE, apply_spec, load_spec_file

from .protocol import (
    FLAG_ESTOP,
    FLAG_ESTOP_BOARD,
    FLAG_WATCHDOG,
    NO_RANGE,
    Clear,
    EStop,
    Frame,
    Motors,
    Status,
)

__all__ = ["BATTERY_FULL_V", "WATCHDOG_S", "Board", "chair_spec"]

WATCHDOG_S = 0.2  # no valid frame for this long: the board zeroes the motors by itself
SLIP = NoiseSpec(0.0, 0.005)  # 0.5 % encoder slip per step: the odometry drifts slowly, as a real chair's
BATTERY_FULL_V = 25.4  # two 12 V lead-acid batteries in series, charged
IDLE_DRAIN_V_PER_S = 2e-4  # electronics alone
DRIVE_DRAIN_V_PER_S = 4e-3  # both motors at full power
FAULT_LOW_BATTERY = 1
LOW_BATTERY_V = 22.0


def chair_spec(name: str, *, path: str = "", start: tuple[float, float, float] = (1.0, 1.0, 0.0)) -> RobotSpec:
    """The chair on the link: the LIACC prototype with mapping cones, as a Real robot.

    Args:
        name: Robot name.
        path: A spec file (``docs/spec.md``) whose ``[chair]`` table may set any registration
            field (width, height, com, max_speed, acceleration_curve, ticks_per_m, sensors,
            noise...); "" for none. The same loader as ``iwz agent --spec``.
        start: Start pose (x m, y m, heading deg).

    Raises:
        ConfigError: An unreadable file, an unknown field, or a value out of range, named.
    """
    x, y, d = start
    spec: RobotSpec = mapping_chair(name, type=RobotType.REAL, x_m=x, y_m=y, dir_deg=d)
    return apply_spec(spec, load_spec_file(path), where=f"{path}: {SPEC_TABLE}") if path else spec


class Board:
    """The chair's boards: motors, encoders, proximity sensors, battery, e-stop, watchdog.

    Args:
        spec: The chair (its start pose set).
        room: The real room (walls and real obstacles).
        seed: Noise seed (sensors and encoder slip).
        dt_s: Board cycle: physics step and status period, s.
    """

    def __init__(self, spec: RobotSpec, room: Lab, *, seed: int = 0, dt_s: float = 0.05) -> None:
        noise = replace(spec.noise, encoder_slip=SLIP)
        self.spec = replace(spec, id=1, type=RobotType.SIMULATED, noise=noise)
        self.world = LocalWorld(room, [self.spec], seed=seed, dt_s=dt_s)
        self.dt_s = dt_s
        self.reading = self.world.step({})[1]
        self.command = (0, 0)  # last Motors asked, 1e-4 units
        self.ack = 0
        self.estop = False
        self.estop_board = False
        self.last_valid_s = -math.inf
        self.battery_v = BATTERY_FULL_V
        self.collisions = 0

    def watchdog(self, now_s: float) -> bool:
        """Whether the watchdog holds the motors (no valid frame for WATCHDOG_S)."""
        return now_s - self.last_valid_s > WATCHDOG_S

    def wheels(self, now_s: float) -> tuple[int, int]:
        """The powers the motors are driven at now (1e-4 units): the command, or zero."""
        if self.estop or self.watchdog(now_s):
            return (0, 0)
        return self.command

    def on_frame(self, frame: Frame, now_s: float) -> None:
        """Acts on a valid frame from the computer (any valid frame feeds the watchdog)."""
        self.last_valid_s = now_s
        msg = frame.msg
        if isinstance(msg, Motors):
            self.command = (msg.left, msg.right)
            self.ack = frame.seq
        elif isinstance(msg, EStop):
            self.estop = True
        elif isinstance(msg, Clear):
            self.estop = self.estop_board = False
            self.command = (0, 0)  # a cleared chair waits for a fresh command
        if self.estop:
            self.command = (0, 0)

    def press_estop(self) -> None:
        """The chair's own e-stop button: latched until the computer sends Clear."""
        self.estop = self.estop_board = True
        self.command = (0, 0)

    def step(self, now_s: float) -> Status:
        """One board cycle at the current wheel powers; returns the status to send."""
        left, right = self.wheels(now_s)
        self.reading = self.world.step({1: (left / 10_000, right / 10_000)})[1]
        if self.reading.collision:
            self.collisions += 1
        drive = (abs(left) + abs(right)) / 3000
        self.battery_v -= (IDLE_DRAIN_V_PER_S + DRIVE_DRAIN_V_PER_S * drive) * self.dt_s
        return self.status(now_s)

    def status(self, now_s: float) -> Status:
        """What the board reports now."""
        by_id = dict(zip(self.reading.proximity_ids, self.reading.proximity_m, strict=True))
        n = max(by_id, default=-1) + 1
        ranges = tuple(
            NO_RANGE if by_id.get(i) is None else min(NO_RANGE - 1, round(1000 * (by_id[i] or 0.0))) for i in range(n)
        )
        flags = (FLAG_ESTOP if self.estop else 0) | (FLAG_ESTOP_BOARD if self.estop_board else 0)
        flags |= FLAG_WATCHDOG if self.watchdog(now_s) else 0
        enc = self.reading.encoders
        return Status(
            ack=self.ack,
            encoders=(_i32(enc[0]), _i32(enc[1])),
            wheels=self.wheels(now_s),
            battery_mv=max(0, round(self.battery_v * 1000)),
            bumpers=1 if self.reading.collision else 0,
            flags=flags,
            fault=FAULT_LOW_BATTERY if self.battery_v < LOW_BATTERY_V else 0,
            ranges_mm=ranges,
        )

    def true_pose(self) -> tuple[float, float, float]:
        """Where the chair really is (x, y, heading deg)."""
        x, y, d = self.world.pose(1)
        return float(x), float(y), float(d)


def _i32(v: int) -> int:
    """Wraps a count to int32, as the board's counters do."""
    return (v + 2**31) % 2**32 - 2**31
