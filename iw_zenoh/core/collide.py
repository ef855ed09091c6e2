"""The native collision check of one tick in one compiled call: the robots taking part picked,
their outlines placed now, half-way and next (:func:`iw_zenoh.core.placing.swept_outlines`), the
contact tests (:mod:`iw_zenoh.core.contact`) run on them, the pairs mapped back to the robots'
indices and the flags set.

Why one call (numba): :func:`iw_zenoh.core.collision.check_collisions` was numpy glue around
two compiled calls (picking the active robots, flags by fancy indexing, a dozen small arrays
returned and boxed one by one), about 22 us of CPU time for a learning environment's one chair
on a loaded machine, most of it fixed costs (now about 9 us): here the flags are written into
one array the caller gives and both kinds of pair come back in one array, so a call boxes one
array and passes few. The operations and their order are the glue's
(``tests/core/test_collide.py`` checks the results against it, array for array). Cached on
disk as the other kernels (``cache=True``).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

from iw_zenoh.core import contact
from iw_zenoh.core.cellgrid import CellGrid, scene_walls
from iw_zenoh.core.contact import _touching
from iw_zenoh.core.lab import Lab, Scene, Wall
from iw_zenoh.core.placing import swept_outlines

__all__ = ["collide", "warm_up"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

_CACHE_KEY = "collide_args"  # where a scene keeps the kernel's arguments about its walls

SceneArgs = tuple[FloatArray, IntArray, IntArray, FloatArray, IntArray, IntArray, FloatArray]


def _scene_args(scene: Scene) -> SceneArgs:
    """The walls' arrays the kernel takes, and the lab's size and cells as one array (fewer
    arguments: each costs the call its unboxing); built once per scene, then kept in its cache."""
    got = scene._cache.get(_CACHE_KEY)
    if isinstance(got, tuple):
        return got
    w = scene_walls(scene)
    g = w.grid
    frame = np.asarray([scene.lab.width_m, scene.lab.height_m, g.x0, g.y0, g.cell, g.nx, g.ny], dtype=np.float64)
    args = (w.segs, w.wall_first, w.wall_count, w.wall_box, w.wall_start, w.wall_items, frame)
    scene._cache[_CACHE_KEY] = args
    return args


def collide(
    scene: Scene,
    outline: FloatArray,
    now: FloatArray,
    nxt: FloatArray,
    active: BoolArray,
    wall_free: BoolArray,
    pass_free: bool,
    flags: BoolArray,
) -> tuple[IntArray, int]:
    """Checks every robot's next pose (the rule of :func:`iw_zenoh.core.contact.touching`).

    Args:
        scene: The lab.
        outline: (N, K, 2) body outlines in each robot's frame, C-contiguous float64.
        now: (N, 3) current poses, C-contiguous float64.
        nxt: (N, 3) next poses, C-contiguous float64.
        active: (N,) robots that take part, or empty: all of them.
        wall_free: (N,) robots that pass through walls and the border, or empty: none.
        pass_free: Whether two robots that both pass through walls (doors) pass each other too.
        flags: (3, N) filled with each robot's ``collided``, ``hit_wall`` and ``hit_robot``.

    Returns:
        ``(pairs, p)``: the ``[robot, wall]`` pairs (the wall index ``len(lab.walls)`` is the
        border) in ``pairs[:p]``, and the ``[i, j]`` (i < j) robot pairs in ``pairs[p:]``, both
        by robot index and sorted.
    """
    return _collide(outline, now, nxt, active, wall_free, pass_free, flags, *_scene_args(scene))


@njit(cache=True, nogil=True)
def _collide(
    outline: FloatArray,
    now: FloatArray,
    nxt: FloatArray,
    active: BoolArray,
    wall_free: BoolArray,
    pass_free: bool,
    flags: BoolArray,
    segs: FloatArray,
    wall_first: IntArray,
    wall_count: IntArray,
    wall_box: FloatArray,
    wall_start: IntArray,
    wall_items: IntArray,
    frame: FloatArray,
) -> tuple[IntArray, int]:  # pragma: no cover
    n = now.shape[0]
    every = True  # every robot takes part (the usual tick): no copies of the arrays
    for i in range(active.shape[0]):
        if not active[i]:
            every = False
            break
    free = wall_free if wall_free.shape[0] else np.zeros(n, dtype=np.bool_)
    if every:
        idx = np.arange(n)
        o, pn, px, wf = outline, now, nxt, free
    else:
        idx = np.flatnonzero(active)
        o, pn, px, wf = outline[idx], now[idx], nxt[idx], free[idx]
    c_now, c_mid, c_next = swept_outlines(o, pn, px)
    g = CellGrid(frame[2], frame[3], frame[4], int(frame[5]), int(frame[6]))
    walls, robots = _touching(
        c_now,
        c_mid,
        c_next,
        wf,
        frame[0],
        frame[1],
        segs,
        wall_first,
        wall_count,
        wall_box,
        wall_start,
        wall_items,
        g,
        pass_free,
    )
    p, q = walls.shape[0], robots.shape[0]
    pairs = np.empty((p + q, 2), dtype=np.int64)
    flags[:] = False
    for t in range(p):
        pairs[t, 0] = idx[walls[t, 0]]
        pairs[t, 1] = walls[t, 1]
        flags[1, pairs[t, 0]] = True
    for t in range(q):
        pairs[p + t, 0] = idx[robots[t, 0]]
        pairs[p + t, 1] = idx[robots[t, 1]]
        flags[2, pairs[p + t, 0]] = True
        flags[2, pairs[p + t, 1]] = True
    for i in range(n):
        flags[0, i] = flags[1, i] or flags[2, i]
    return pairs, p


def warm_up() -> None:
    """Compiles the kernel now (or loads it from the cache), with the contact kernel it calls."""
    contact.warm_up()
    scene = Scene(Lab("warm-up", 4.0, 4.0, (Wall(((1.0, 1.0), (2.0, 1.0), (2.0, 2.0)), 1.0),)))
    sq = np.asarray([[[-0.1, -0.1], [0.1, -0.1], [0.1, 0.1], [-0.1, 0.1]]] * 2)
    none = np.zeros(0, dtype=np.bool_)
    collide(scene, sq, np.zeros((2, 3)), np.ones((2, 3)), none, none, True, np.empty((3, 2), dtype=np.bool_))
