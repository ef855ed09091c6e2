"""Movement noise: each robot's standard normals drawn from its own seeded stream, so a robot
moves the same whatever else registers, leaves or draws."""

from __future__ import annotations

import numpy as np

from iw_zenoh.core.noise import Stream, rng_for, standard_normals

__all__ = ["MotionNoise"]


class MotionNoise:
    """The movement-noise streams of a run's robots, built once per robot.

    Args:
        seed: The run's seed.
    """

    def __init__(self, seed: int) -> None:
        self.seed = seed
        self._rngs: dict[int, np.random.Generator] = {}

    def normals(self, ids: list[int]) -> np.ndarray:
        """(N, 2) this tick's standard normals, one row per robot of ``ids``, in that order."""
        return standard_normals([self._rng(rid) for rid in ids], 2)

    def forget(self, robot_id: int) -> None:
        """Drops a removed robot's stream."""
        self._rngs.pop(robot_id, None)

    def _rng(self, rid: int) -> np.random.Generator:
        g = self._rngs.get(rid)
        if g is None:
            g = self._rngs[rid] = rng_for(self.seed, rid, Stream.MOTION)
        return g
