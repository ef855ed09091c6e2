"""Seeded random streams: one generator per robot and per sensor kind, derived from one seed.

Deriving a stream from ``(seed, robot_id, stream)`` rather than from the order robots were
created in keeps a robot's noise the same whichever process (or sensor shard) computes it.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from iw_zenoh import pools

if TYPE_CHECKING:
    from concurrent.futures import Future

__all__ = ["NoiseBank", "NoiseStreams", "Stream", "rng_for", "standard_normals"]


class Stream(enum.IntEnum):
    """The independent random streams of one robot."""

    MOTION = 0  # movement noise (the world)
    SENSORS = 1  # every sensor of the robot, in fixed slots (see core.sensors)


def rng_for(seed: int, robot_id: int, stream: Stream) -> np.random.Generator:
    """The generator of one robot's stream.

    Args:
        seed: The run's seed.
        robot_id: The robot's id.
        stream: Which of its streams.

    Returns:
        A PCG64 generator, the same for the same arguments on every machine.
    """
    ss = np.random.SeedSequence(entropy=seed, spawn_key=(robot_id, int(stream)))
    return np.random.Generator(np.random.PCG64(ss))


def standard_normals(rngs: list[np.random.Generator], k: int) -> npt.NDArray[np.float64]:
    """Draws ``k`` standard normals from each generator.

    Args:
        rngs: One generator per robot, length N.
        k: Draws per robot.

    Returns:
        Array of shape (N, k).
    """
    out = np.empty((len(rngs), k), dtype=np.float64)
    for i, g in enumerate(rngs):
        out[i] = g.standard_normal(k)
    return out


class NoiseBank:
    """Standard normals for many robots, a fixed number per robot per tick, drawn in blocks.

    Robot i's generator is asked for ``block`` ticks' worth of its values at once, in row-major
    order, which is exactly the sequence it would give one tick at a time: the values do not
    depend on ``block``. One generator call per robot per block instead of per tick.

    Args:
        rngs: One generator per robot.
        counts: (N,) values per robot per tick.
        block: Ticks drawn per refill.
    """

    def __init__(self, rngs: list[np.random.Generator], counts: npt.NDArray[np.int64], *, block: int = 32) -> None:
        self._rngs = rngs
        self._counts = [int(c) for c in counts]
        self._starts = np.concatenate([[0], np.cumsum(self._counts)]).astype(np.int64)
        self._block = block
        self._buf = np.zeros((block, int(self._starts[-1])))
        self._row = block

    def next(self) -> npt.NDArray[np.float64]:
        """This tick's values, shape (sum(counts),), robot i's at ``starts[i]:starts[i+1]``."""
        if self._row == self._block:
            for i, g in enumerate(self._rngs):
                a, b = self._starts[i], self._starts[i + 1]
                if b > a:
                    self._buf[:, a:b] = g.standard_normal((self._block, b - a))
            self._row = 0
        row = np.array(self._buf[self._row], dtype=np.float64)
        self._row += 1
        return row


class NoiseStreams:
    """Each robot's own stream of standard normals, drawn ahead in blocks and taken in any counts.

    Taking ``c`` values gives exactly what ``standard_normal(c)`` on the robot's generator would
    have given next, whatever was taken before and whichever robots come and go (a generator's
    draws do not depend on how they are split into calls); only the number of generator calls
    falls, from one per robot per tick to one per robot per ``block`` values.

    Args:
        seed: The run's seed.
        stream: Which of each robot's streams.
        block: Values drawn ahead per refill (at least what one take asks for).
        threads: Draw a many-robot roster's ticks ahead (:meth:`fill`) on up to this many
            threads, robot after robot in runs (each robot has its own generator, and numpy's
            draws release the GIL): the same values.
    """

    def __init__(self, seed: int, stream: Stream, *, block: int = 512, threads: int = 1) -> None:
        self.seed = seed
        self.stream = stream
        self.block = block
        self.threads = threads
        self._rngs: dict[int, np.random.Generator] = {}
        self._buf: dict[int, npt.NDArray[np.float64]] = {}
        self._pos: dict[int, int] = {}
        self._rows: _Rows | None = None  # the roster's ticks drawn ahead by fill
        self._ahead: Future[_Rows] | None = None  # the roster's rows after those, being drawn on a thread

    def take(self, robot_id: int, count: int) -> npt.NDArray[np.float64]:
        """The robot's next ``count`` values (a view: copy it if it is kept)."""
        self._hand_back()
        return self._take(robot_id, count)

    def _take(self, robot_id: int, count: int) -> npt.NDArray[np.float64]:
        buf = self._buf.get(robot_id)
        pos = self._pos.get(robot_id, 0)
        if buf is None or pos + count > len(buf):
            g = self._rngs.get(robot_id)
            if g is None:  # built once per robot (a generator costs ~20 us to build)
                g = self._rngs[robot_id] = rng_for(self.seed, robot_id, self.stream)
            rest = buf[pos:] if buf is not None else np.zeros(0)
            buf = self._buf[robot_id] = np.concatenate([rest, g.standard_normal(max(self.block, count))])
            pos = 0
        self._pos[robot_id] = pos + count
        return buf[pos : pos + count]

    def _take_into(self, robot_id: int, out: npt.NDArray[np.float64]) -> None:
        """Writes the robot's next ``len(out)`` values to ``out`` (1-D, contiguous): what is
        left of its block first, then straight from its generator, drawing no more than that."""
        buf = self._buf.get(robot_id)
        pos = self._pos.get(robot_id, 0)
        k = 0
        if buf is not None and pos < len(buf):
            k = min(len(buf) - pos, len(out))
            out[:k] = buf[pos : pos + k]
            self._pos[robot_id] = pos + k
        if k < len(out):
            g = self._rngs.get(robot_id)
            if g is None:
                g = self._rngs[robot_id] = rng_for(self.seed, robot_id, self.stream)
            g.standard_normal(out=out[k:])

    def fill(
        self, ids: list[int], counts: list[int], starts: list[int], only: list[bool], out: npt.NDArray[np.float64]
    ) -> None:
        """Writes robot ``ids[i]``'s next ``counts[i]`` values to ``out[starts[i]:]`` for each ``i``
        with ``only[i]``: what :meth:`take` gives, robot after robot, in one call; the other slots
        of ``out`` are left as they are.

        The same roster (ids, counts, only) tick after tick is served from a block of the next
        :data:`ROWS_BYTES`-bounded number of ticks drawn at once, robot by robot, in the order
        take would give them (a tick of 256 robots paid a Python loop over them, ~1 ms; now the
        loop runs once a block and a tick copies one row); a robot's values not used when the
        roster changes, or when take is called, go back to the front of its stream.
        """
        rows = self._rows
        if rows is None or rows.row == len(rows.buf) or rows.key != (ids, counts, only):
            if rows is not None and self._ahead is not None and rows.key == (ids, counts, only):
                ahead, self._ahead = self._ahead, None  # (out first: a failed draw is raised once)
                rows = self._rows = ahead.result()  # the next rows, drawn while these were used
            else:
                self._hand_back()
                rows = self._rows = self._draw_rows(ids, counts, starts, only)
            if self.threads > 1 and len(ids) >= THREADS_FROM:
                # the rows after these, on a thread of their own while the caller goes on (the
                # robots' streams are not touched here until they are done: take, another
                # roster and hand-back wait for them)
                self._ahead = pools.submit_ahead(self._draw_rows, list(ids), list(counts), list(starts), list(only), 1)
        r = rows.buf[rows.row]
        rows.row += 1
        if rows.mask is None:
            out[: len(r)] = r
        else:
            out[rows.mask] = r[rows.mask]

    def _draw_rows(
        self, ids: list[int], counts: list[int], starts: list[int], only: list[bool], threads: int | None = None
    ) -> _Rows:
        """The next ticks of a roster, one row a tick in ``fill``'s layout (robot ``i``'s values of
        tick ``t`` at ``[t, starts[i]:starts[i] + counts[i]]``), drawn on up to ``threads``
        threads (default :attr:`threads`)."""
        total = max((s0 + c for s0, c in zip(starts, counts, strict=True)), default=0)
        ticks = max(1, min(ROWS_MAX, ROWS_BYTES // (8 * max(total, 1))))
        buf = np.zeros((ticks, total))
        mask = np.zeros(total, dtype=bool)
        jobs = [(rid, c, s0) for rid, c, s0, mine in zip(ids, counts, starts, only, strict=True) if mine and c]
        for _, c, s0 in jobs:
            mask[s0 : s0 + c] = True

        def draw(part: list[tuple[int, int, int]]) -> None:
            for rid, c, s0 in part:  # the robots' own generators and slots: runs may go on threads
                vals = np.empty(ticks * c)
                self._take_into(rid, vals)
                buf[:, s0 : s0 + c] = vals.reshape(ticks, c)

        k = min(self.threads if threads is None else threads, len(jobs) // THREADS_FROM)
        if k > 1:
            pools.run_all(draw, [jobs[i * len(jobs) // k : (i + 1) * len(jobs) // k] for i in range(k)])
        else:
            draw(jobs)
        return _Rows((list(ids), list(counts), list(only)), list(starts), buf, None if mask.all() else mask)

    def _hand_back(self) -> None:
        """Puts the values of the drawn-ahead ticks not used yet back in front of each robot's
        stream (what take and a new roster's block then give first)."""
        blocks = [self._rows] if self._rows is not None and self._rows.row < len(self._rows.buf) else []
        ahead, self._ahead = self._ahead, None
        self._rows = None
        if ahead is not None:
            blocks.append(ahead.result())  # drawn after the rows in use: given after them
        if not blocks:
            return
        ids, counts, only = blocks[0].key
        for rid, c, s0, mine in zip(ids, counts, blocks[0].starts, only, strict=True):
            if mine and c:
                rest = np.concatenate([b.buf[b.row :, s0 : s0 + c].ravel() for b in blocks])
                buf = self._buf.get(rid)
                after = buf[self._pos.get(rid, 0) :] if buf is not None else np.zeros(0)
                self._buf[rid] = np.concatenate([rest, after])
                self._pos[rid] = 0


THREADS_FROM = 16  # robots a thread at least (fewer: one thread draws them all)


ROWS_BYTES = 1 << 22  # fill draws at most this much ahead (4 MB: 256 chairs of 78 values, 26 ticks)
ROWS_MAX = 64  # and at most this many ticks


@dataclass
class _Rows:
    """A roster's ticks drawn ahead by :meth:`NoiseStreams.fill`."""

    key: tuple[list[int], list[int], list[bool]]  # ids, counts, only
    starts: list[int]
    buf: npt.NDArray[np.float64]  # (ticks, slots): a tick a row
    mask: npt.NDArray[np.bool_] | None  # the slots of robots drawn (None: all)
    row: int = 0  # the next tick's row
