"""The laser scanners' ray cast, compiled: every beam of every scanner of one tick in one call.

A beam reads the distance from its scanner's mounting point to the first wall edge (walls,
obstacles added at run time and the lab's border are all walls of the scene) or edge of another
robot's body (chairs, doors) that it meets, ``inf`` when that is beyond the scanner's range. A
mounting point inside a wall or another body reads 0 on every beam, as a proximity cone does.

How: walls and bodies are looked up in the cell grid of :mod:`iw_zenoh.core.cellgrid`, over the
cells the scanner's range covers; each candidate edge within range is tested only against the
beams whose directions fall in the angle it subtends from the scanner (plus one beam either
side, so a beam through an end point is never lost to rounding), so the work grows with edges
plus hits rather than edges times beams. Compiled with numba and cached next to this file
(``cache=True``), as the cones' kernel (:mod:`iw_zenoh.core.cones`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.cellgrid import SceneIndex, SceneWalls, cell_range, gather, in_convex, in_walls, scene_index
from iw_zenoh.core.lab import Lab, Scene, Wall
from iw_zenoh.core.placing import mod_two_pi, mounts, outline_at

__all__ = ["laser_distances", "laser_ranges", "warm_up"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

END_SLACK = 1e-12  # a hit this close past an edge's end still counts (a beam through a corner)
TWO_PI = 2.0 * math.pi


def laser_distances(
    scene: Scene,
    bodies: Bodies,
    pose: FloatArray,
    *,
    only: npt.NDArray[np.bool_] | None = None,
    index: SceneIndex | None = None,
) -> FloatArray:
    """The true range every beam of every robot's laser scanners reads.

    Args:
        scene: The lab's geometry.
        bodies: The robots (N).
        pose: (N, 3) poses.
        only: (N,) compute the scanners of these robots only (a sensor shard); every robot is still
            an obstacle to them. The others read ``inf``.
        index: :func:`~iw_zenoh.core.cellgrid.scene_index` of ``scene`` and the bodies at ``pose``,
            when the caller has it already.

    Returns:
        (L,) ranges in :attr:`~iw_zenoh.core.bodies.Lasers.first` order, ``inf`` beyond range.
    """
    lz = bodies.lasers
    if only is None or np.all(only):  # every scanner (the usual tick): no selection arrays
        if not len(lz.owner):
            return np.full(int(lz.first[-1]), np.inf)
        pose = np.ascontiguousarray(pose, dtype=np.float64)
        ox, oy = mounts(pose, lz.owner, lz.xy, np.arange(len(lz.owner)))
        ix = scene_index(scene, outline_at(bodies.outline, pose)) if index is None else index
        return np.asarray(
            _scan(ox, oy, pose[lz.owner, 2] + lz.start_rad, lz.step_rad, lz.first, lz.range_m, lz.owner, ix),
            dtype=np.float64,
        )
    out = np.full(int(lz.first[-1]), np.inf)
    sel = np.asarray(only, dtype=bool)[lz.owner]
    if not sel.any():
        return out
    own = lz.owner[sel]
    c, s = np.cos(pose[own, 2]), np.sin(pose[own, 2])
    lx, ly = lz.xy[sel, 0], lz.xy[sel, 1]
    got = laser_ranges(
        scene,
        pose[own, 0] + c * lx - s * ly,
        pose[own, 1] + s * lx + c * ly,
        pose[own, 2] + lz.start_rad[sel],
        lz.step_rad[sel],
        lz.beams[sel],
        lz.range_m[sel],
        own,
        bodies.world_outline(pose),
        index=index,
    )
    out[np.repeat(sel, lz.beams)] = got
    return out


def laser_ranges(
    scene: Scene,
    ox: FloatArray,
    oy: FloatArray,
    start_rad: FloatArray,
    step_rad: FloatArray,
    beams: IntArray,
    range_m: FloatArray,
    owner: IntArray,
    body_xy: FloatArray,
    *,
    index: SceneIndex | None = None,
) -> FloatArray:
    """The range every beam of every scanner reads.

    Args:
        scene: The lab.
        ox: (S,) each scanner's mounting point x in the world, metres.
        oy: (S,) mounting point y.
        start_rad: (S,) world direction of each scanner's first beam.
        step_rad: (S,) angle between neighbouring beams (beam j looks ``start + j * step``).
        beams: (S,) beams of each scanner, >= 1.
        range_m: (S,) ranges.
        owner: (S,) the body each scanner is mounted on (it does not see itself).
        body_xy: (N, K, 2) every body's outline in the world, counter-clockwise.
        index: :func:`~iw_zenoh.core.cellgrid.scene_index` of ``scene`` and ``body_xy``, if built.

    Returns:
        (sum(beams),) the ranges, scanner after scanner, first beam first; ``inf`` where a beam
        meets nothing within range.
    """
    beams = np.ascontiguousarray(beams, dtype=np.int64)
    first = np.concatenate([[0], np.cumsum(beams)]).astype(np.int64)
    return np.asarray(
        _scan(
            np.ascontiguousarray(ox, dtype=np.float64),
            np.ascontiguousarray(oy, dtype=np.float64),
            np.ascontiguousarray(start_rad, dtype=np.float64),
            np.ascontiguousarray(step_rad, dtype=np.float64),
            first,
            np.ascontiguousarray(range_m, dtype=np.float64),
            np.ascontiguousarray(owner, dtype=np.int64),
            scene_index(scene, body_xy) if index is None else index,
        ),
        dtype=np.float64,
    )


@njit(cache=True, nogil=True)
def _seg_dist(ax: float, ay: float, bx: float, by: float) -> float:  # pragma: no cover
    """Distance from the origin to segment a-b."""
    dx = bx - ax
    dy = by - ay
    dd = dx * dx + dy * dy
    t = 0.0
    if dd > 0.0:
        t = min(max(-(ax * dx + ay * dy) / dd, 0.0), 1.0)
    qx = ax + t * dx
    qy = ay + t * dy
    return math.sqrt(qx * qx + qy * qy)


@njit(cache=True, nogil=True)
def _cast(
    ax: float,
    ay: float,
    bx: float,
    by: float,
    rng: float,
    start: float,
    step: float,
    cs: FloatArray,
    sn: FloatArray,
    out: FloatArray,
    off: int,
    nb: int,
) -> None:  # pragma: no cover
    """Lowers ``out[off:off+nb]`` where beams (unit directions ``cs``, ``sn``) meet segment a-b,
    given relative to the scanner: only the beams within the angle the segment subtends."""
    if _seg_dist(ax, ay, bx, by) > rng:
        return
    ex = bx - ax
    ey = by - ay
    if nb > 1 and step > 0.0:
        ta = mod_two_pi(math.atan2(ay, ax) - start)
        tb = mod_two_pi(math.atan2(by, bx) - start)
        sweep = mod_two_pi(tb - ta + math.pi) - math.pi
        lo = ta if sweep >= 0.0 else tb
        width = abs(sweep)
        for shift in (-TWO_PI, 0.0, TWO_PI):  # the arc may wrap past the first beam either way
            a = int(math.ceil((lo - shift) / step)) - 1
            b = int(math.floor((lo + width - shift) / step)) + 1
            a = max(a, 0)
            b = min(b, nb - 1)
            for j in range(a, b + 1):
                _hit(ax, ay, ex, ey, cs[j], sn[j], out, off + j)
        return
    for j in range(nb):
        _hit(ax, ay, ex, ey, cs[j], sn[j], out, off + j)


@njit(cache=True, nogil=True)
def _hit(
    ax: float, ay: float, ex: float, ey: float, dx: float, dy: float, out: FloatArray, k: int
) -> None:  # pragma: no cover
    """Lowers ``out[k]`` to where the ray from the origin along (dx, dy) meets segment a + u e."""
    den = dx * ey - dy * ex
    if den == 0.0:
        return  # parallel: the edges either side of it hold the hit
    t = (ax * ey - ay * ex) / den
    u = (ax * dy - ay * dx) / den
    if t >= 0.0 and -END_SLACK <= u <= 1.0 + END_SLACK and t < out[k]:
        out[k] = t


HELD_MAX = 8  # walls whose boxes hold one scanner, at most (more: no edge is skipped)


@njit(cache=True, nogil=True)
def _holding(w: SceneWalls, px: float, py: float, held: IntArray) -> int:  # pragma: no cover
    """The edges (``[first, end)`` rows of ``held``) of the walls whose boxes hold p; how many,
    or -1 when more than :data:`HELD_MAX` do."""
    if w.wall_box.shape[0] == 0:
        return 0
    g, box = w.grid, w.wall_box
    c0, _ = cell_range(px, px, g.x0, g.cell, g.nx)
    r0, _ = cell_range(py, py, g.y0, g.cell, g.ny)
    q = r0 * g.nx + c0
    n = 0
    for j in range(w.wall_start[q], w.wall_start[q + 1]):
        k = w.wall_items[j]
        if box[k, 0] <= px <= box[k, 2] and box[k, 1] <= py <= box[k, 3]:
            if n == held.shape[0]:
                return -1
            held[n, 0] = w.wall_first[k]
            held[n, 1] = w.wall_first[k] + w.wall_count[k]
            n += 1
    return n


@njit(cache=True, nogil=True, inline="always")
def _held(s: int, held: IntArray, n: int) -> bool:  # pragma: no cover
    """Whether edge ``s`` is one of :func:`_holding`'s (every edge is, when it gave -1)."""
    if n < 0:
        return True
    for e in range(n):  # noqa: SIM110 (a loop numba compiles; any() of a generator it does not)
        if held[e, 0] <= s < held[e, 1]:
            return True
    return False


@njit(cache=True, nogil=True)
def _scan(
    ox: FloatArray,
    oy: FloatArray,
    start: FloatArray,
    step: FloatArray,
    first: IntArray,
    rng: FloatArray,
    owner: IntArray,
    ix: SceneIndex,
) -> FloatArray:  # pragma: no cover
    out = np.full(first[ox.shape[0]], np.inf)
    turn_c, turn_s = beam_turns(step, first)
    _scan_part(0, ox.shape[0], ox, oy, start, step, first, rng, owner, ix, turn_c, turn_s, out)
    return out


@njit(cache=True, nogil=True)
def beam_turns(step: FloatArray, first: IntArray) -> tuple[FloatArray, FloatArray]:  # pragma: no cover
    """(L,) ``cos`` and ``sin`` of each beam's turn from its scanner's first beam (``j * step``):
    a tick turns them by the first beam's direction instead of taking two transcendentals a
    beam (they were half the laser's time). The same for a roster every tick: worked out once."""
    n = first[step.shape[0]]
    c, s = np.empty(n), np.empty(n)
    for i in range(step.shape[0]):
        for j in range(first[i + 1] - first[i]):
            c[first[i] + j] = math.cos(j * step[i])
            s[first[i] + j] = math.sin(j * step[i])
    return c, s


@njit(cache=True, nogil=True)
def _scan_part(
    i0: int,
    i1: int,
    ox: FloatArray,
    oy: FloatArray,
    start: FloatArray,
    step: FloatArray,
    first: IntArray,
    rng: FloatArray,
    owner: IntArray,
    ix: SceneIndex,
    turn_c: FloatArray,
    turn_s: FloatArray,
    out: FloatArray,
) -> None:  # pragma: no cover
    """Scanners ``i0`` to ``i1 - 1``: their beams' ranges written to ``out`` (``inf`` before);
    ``turn_c``, ``turn_s``: :func:`beam_turns`, by beam as ``out``."""
    w, g = ix.walls, ix.walls.grid
    segs, side, seg_box, bbox, body_xy = w.segs, w.seg_side, w.seg_box, ix.bbox, ix.body_xy
    k = body_xy.shape[1]
    seen_seg = np.full(segs.shape[0], -1, dtype=np.int64)
    seen_body = np.full(bbox.shape[0], -1, dtype=np.int64)
    near_seg = np.empty(segs.shape[0], dtype=np.int64)
    near_body = np.empty(bbox.shape[0], dtype=np.int64)
    most = 0
    for i in range(i0, i1):
        most = max(most, first[i + 1] - first[i])
    cs = np.empty(most)
    sn = np.empty(most)
    held = np.empty((HELD_MAX, 2), dtype=np.int64)
    for i in range(i0, i1):
        px, py, r = ox[i], oy[i], rng[i]
        off, nb = first[i], first[i + 1] - first[i]
        c0, s0 = math.cos(start[i]), math.sin(start[i])
        for j in range(nb):  # the first beam's direction turned by j steps
            tc, ts = turn_c[off + j], turn_s[off + j]
            cs[j] = tc * c0 - ts * s0
            sn[j] = ts * c0 + tc * s0
        x0, y0, x1, y1 = px - r, py - r, px + r, py + r
        blind = False  # the mounting point is inside something
        n_held = _holding(w, px, py, held)
        for t in range(gather(g, w.seg_start, w.seg_items, seg_box, seen_seg, i, x0, y0, x1, y1, near_seg)):
            s = near_seg[t]
            ax, ay, bx, by = segs[s, 0] - px, segs[s, 1] - py, segs[s, 2] - px, segs[s, 3] - py
            # only an edge with its wall away from the scanner can hold a beam's first hit (a
            # beam from outside a wall enters it there): the others are skipped, except the
            # edges of a wall whose box holds the scanner (on its outline, the even-odd rule
            # may call a scanner outside: there every edge is tested, as shapely's cast does)
            if side[s] * ((bx - ax) * (-ay) - (by - ay) * (-ax)) <= 0.0 or _held(s, held, n_held):
                _cast(ax, ay, bx, by, r, start[i], step[i], cs, sn, out, off, nb)
        for t in range(gather(g, ix.b_start, ix.b_items, bbox, seen_body, i, x0, y0, x1, y1, near_body)):
            b = near_body[t]
            if b == owner[i]:
                continue
            if bbox[b, 0] <= px <= bbox[b, 2] and bbox[b, 1] <= py <= bbox[b, 3] and in_convex(px, py, body_xy[b], k):
                blind = True
            for e in range(k):
                f = (e + 1) % k
                ax, ay = body_xy[b, e, 0] - px, body_xy[b, e, 1] - py
                bx, by = body_xy[b, f, 0] - px, body_xy[b, f, 1] - py
                # only edges facing the scanner can hold a convex body's first hit
                if (bx - ax) * (-ay) - (by - ay) * (-ax) <= 0.0 and (ax != bx or ay != by):
                    _cast(ax, ay, bx, by, r, start[i], step[i], cs, sn, out, off, nb)
        if not blind and in_walls(w, px, py):
            blind = True
        for j in range(off, off + nb):
            if blind:
                out[j] = 0.0
            elif out[j] > r:
                out[j] = math.inf


def warm_up() -> None:
    """Compiles the kernel now (or loads it from the cache), so the first tick is not slow."""
    scene = Scene(Lab("warm-up", 4.0, 4.0, (Wall(((1.0, 1.0), (2.0, 1.0), (2.0, 2.0)), 1.0),)))
    one = np.zeros(1)
    laser_ranges(
        scene,
        one + 0.5,
        one + 0.5,
        one,
        one + 0.1,
        np.asarray([4], dtype=np.int64),
        one + 3.0,
        np.zeros(1, dtype=np.int64),
        np.asarray([[[0.1, 0.1], [0.3, 0.1], [0.3, 0.3], [0.1, 0.3]]]),
    )
