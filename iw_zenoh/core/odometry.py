"""Dead reckoning from a differential-drive chair's wheel encoders: the serial bridge's odometry
of a real chair (``bridges/serial/bridge.py``) and the emulated chair's (``agents/emulated.py``)."""

from __future__ import annotations

import math

__all__ = ["WheelOdometry"]


class WheelOdometry:
    """Dead reckoning from wrapping int32 encoder counts (differential drive).

    Args:
        pose: Start (x m, y m, heading deg).
        wheel_base_m: Distance between the wheels.
        ticks_per_m: Encoder ticks per metre.
        counts: The encoders' counts at the start pose (an emulated chair's count from zero);
            ``None``: the first update's counts are the baseline (a board's counts are
            wherever it left them).

    Example:
        >>> odo = WheelOdometry((0.0, 0.0, 0.0), 0.5, 1000.0, counts=(0, 0))
        >>> odo.update((1000, 1000))
        (1.0, 0.0, 0.0)
    """

    def __init__(
        self,
        pose: tuple[float, float, float],
        wheel_base_m: float,
        ticks_per_m: float,
        *,
        counts: tuple[int, int] | None = None,
    ) -> None:
        self.x, self.y = pose[0], pose[1]
        self.th = math.radians(pose[2])
        self.base = wheel_base_m
        self.per_m = ticks_per_m
        self._last = counts

    def forget(self) -> None:
        """The next counts are a new baseline (the link was down, the board may have restarted)."""
        self._last = None

    def update(self, counts: tuple[int, int]) -> tuple[float, float, float]:
        """Advances by the counts since the last call; returns (x, y, heading deg)."""
        if self._last is not None:
            dl = _wrap(counts[0] - self._last[0]) / self.per_m
            dr = _wrap(counts[1] - self._last[1]) / self.per_m
            d, dth = 0.5 * (dl + dr), (dr - dl) / self.base
            mid = self.th + 0.5 * dth
            self.x += d * math.cos(mid)
            self.y += d * math.sin(mid)
            self.th = math.remainder(self.th + dth, 2 * math.pi)
        self._last = counts
        return self.pose

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, heading deg)."""
        return self.x, self.y, math.degrees(self.th)


def _wrap(d: int) -> int:
    return (d + 2**31) % 2**32 - 2**31
