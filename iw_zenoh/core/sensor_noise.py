"""Where each sensor's noise comes from: the fixed layout of one tick's standard normals.

Each robot draws, every tick, one standard normal per slot from its own sensor stream
(:data:`~iw_zenoh.core.noise.Stream.SENSORS`): one per proximity sensor in order, then compass,
each beacon, GPS x, y and heading, left and right encoder, then one per laser beam (scanner
after scanner; a robot without a scanner draws none, so its noise is what it was before scanners
existed). Switching one sensor's noise off
leaves every other sensor's noise unchanged, and a robot's readings do not depend on the others.
:func:`~iw_zenoh.core.sensors.read_sensors` reads them.
"""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.noise import NoiseBank, Stream, rng_for

__all__ = ["TickNormals", "noise_bank", "noise_layout", "tick_normals"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


# a roster's layout is the same every tick: worked out once per roster (Bodies hash by identity)
# and kept for the few rosters in use (states of an older revision may still be in flight)
ROSTERS_KEPT = 8


@lru_cache(maxsize=ROSTERS_KEPT)
def noise_layout(bodies: Bodies, n_beacons: int) -> tuple[IntArray, IntArray]:
    """Per robot, how many standard normals a tick draws and where its slots start.

    Args:
        bodies: The robots.
        n_beacons: Beacons in the lab.

    Returns:
        ``(counts, starts)``, both (N,), read-only (shared by every tick of this roster): robot
        i's draws are ``z[starts[i]:starts[i]+counts[i]]``.
    """
    m = np.bincount(bodies.ir_owner, minlength=bodies.n).astype(np.int64)
    beams = np.bincount(bodies.lasers.owner, weights=bodies.lasers.beams, minlength=bodies.n).astype(np.int64)
    counts = m + 1 + n_beacons + 3 + 2 + beams
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    counts.setflags(write=False)
    starts.setflags(write=False)
    return counts, starts


def noise_bank(bodies: Bodies, n_beacons: int, seed: int, *, block: int = 32) -> NoiseBank:
    """The sensor noise source of these robots: each robot's own stream, seeded from ``seed``.

    Args:
        bodies: The robots.
        n_beacons: Beacons in the lab.
        seed: The run's seed.
        block: Ticks drawn at once (the values do not depend on it).

    Returns:
        A bank whose :meth:`~iw_zenoh.core.noise.NoiseBank.next` feeds :func:`~iw_zenoh.core.sensors.read_sensors`.
    """
    counts, _ = noise_layout(bodies, n_beacons)
    return NoiseBank([rng_for(seed, int(i), Stream.SENSORS) for i in bodies.ids], counts, block=block)


class TickNormals(NamedTuple):
    """One tick's standard normals, cut out of the :func:`noise_layout` by sensor kind."""

    proximity: FloatArray  # (M,) one per proximity sensor
    compass: FloatArray  # (N,)
    beacon: FloatArray  # (N, B)
    gps: FloatArray  # (N, 3) x, y and heading
    encoder: FloatArray  # (N, 2) left and right
    laser: FloatArray  # (L,) one per laser beam


def tick_normals(bodies: Bodies, z: FloatArray, n_beacons: int) -> TickNormals:
    """Cuts one tick's flat normals into each sensor kind's slots, robot by robot.

    Args:
        bodies: The robots.
        z: The tick's standard normals in :func:`noise_layout` order.
        n_beacons: Beacons in the lab, carried ones included.

    Returns:
        The normals of each sensor kind.
    """
    s = _slots(bodies, n_beacons)
    return TickNormals(
        proximity=z[s.proximity],
        compass=z[s.compass],
        beacon=z[s.beacon] if n_beacons else np.zeros((bodies.n, 0)),
        gps=z[s.gps],
        encoder=z[s.encoder],
        laser=z[s.laser],
    )


class _Slots(NamedTuple):
    """Where each sensor kind's normals are in a tick's flat array (indices, shaped as
    :class:`TickNormals`)."""

    proximity: IntArray
    compass: IntArray
    beacon: IntArray
    gps: IntArray
    encoder: IntArray
    laser: IntArray


@lru_cache(maxsize=ROSTERS_KEPT)
def _slots(bodies: Bodies, n_beacons: int) -> _Slots:
    """The slots of :func:`tick_normals`, worked out once per roster."""
    n = bodies.n
    _, starts = noise_layout(bodies, n_beacons)
    own = bodies.ir_owner
    first = np.searchsorted(own, np.arange(n))
    m_slot = starts[own] + (np.arange(len(own)) - first[own])
    after = starts + np.bincount(own, minlength=n).astype(np.int64)  # first slot after the proximity ones
    lz = bodies.lasers
    b_own = lz.beam_owner
    b_first = np.searchsorted(b_own, np.arange(n))
    l_slot = (after + 6 + n_beacons)[b_own] + (np.arange(len(b_own)) - b_first[b_own])
    return _Slots(
        proximity=m_slot,
        compass=after,
        beacon=after[:, None] + 1 + np.arange(n_beacons)[None, :],
        gps=after[:, None] + 1 + n_beacons + np.arange(3)[None, :],
        encoder=after[:, None] + 4 + n_beacons + np.arange(2)[None, :],
        laser=l_slot,
    )
