"""What the legacy bridge hears of the world over the bus: its description (asked for while none
has come), committed states, ticks, collision verdicts, sensor batches and what the radio
delivered, each decoded and, where it carries a tick, held to the tick window."""

from __future__ import annotations

import time
from typing import TypeVar

from iw_zenoh import keys
from iw_zenoh.bus import Queue
from iw_zenoh.errors import IwError, ProtocolError
from iw_zenoh.messages import Message, RadioBatch, SensorBatch, Tick, Verdict, WorldInfo, WorldState, decode
from iw_zenoh.process.runtime import NodeIO
from iw_zenoh.ticks import TickWindow

from .transport import QueueBus

__all__ = ["INFO_ASK_S", "WorldFeed"]

INFO_ASK_S = 5.0  # while no world has answered, its description is asked at most this often

M = TypeVar("M", bound=Message)


class WorldFeed:
    """The world as the bridge hears it, taken from Zenoh's own queues by the bridge's loop.

    Args:
        bus: The bus.
        sim: Simulation name.
        io: The bridge's node handle (messages from too far ahead are reported through it).
        window: The tick window (:mod:`iw_zenoh.ticks`).

    Attributes:
        info: The world's latest description, or None before one came.
    """

    def __init__(self, bus: QueueBus, sim: str, io: NodeIO, window: TickWindow) -> None:
        self.bus, self.sim, self.io, self.window = bus, sim, io, window
        self.info: WorldInfo | None = None
        # Zenoh's own queues, polled by the UDP loop every millisecond: no Python callback thread
        # competing for the interpreter lock with the loop 100 times a cycle (that contention,
        # not the work, was most of the Measures jitter at 100 robots)
        self._states = bus.queue(keys.state(sim), 64)
        self._ticks = bus.queue(keys.tick(sim), 64)
        self._readings = bus.queue(keys.all_sensor_batches(sim), 256)  # every shard's batch
        self._hears = bus.queue(keys.radio(sim), 256)  # the radio's batch: one message a tick
        self._infos = bus.queue(keys.info(sim), 16)
        self._verdicts = bus.queue(keys.verdict(sim), 64)  # which collisions were walls, which robots
        self._info_asked = -INFO_ASK_S

    def world_info(self, *, now_or_never: bool = False) -> WorldInfo | None:
        """The world's description; asked (waiting up to 2 s) at most every INFO_ASK_S while no
        world answers (asked for every registration, a flood of them froze the loop), or at once
        with ``now_or_never`` (a world has just answered, so it is there)."""
        now = time.monotonic()
        if self.info is None and (now_or_never or now - self._info_asked >= INFO_ASK_S):
            self._info_asked = now
            for data in self.bus.query(keys.info(self.sim), timeout_s=2.0):
                try:
                    self.info = decode(data, WorldInfo)
                except IwError:
                    continue
        return self.info

    def take_info(self) -> None:
        """Keeps the latest description the world published."""
        for info in _decoded(self._infos, WorldInfo)[-1:]:
            self.info = info

    def verdicts(self) -> list[Verdict]:
        """The collision verdicts waiting, within the window."""
        return self._current(self._verdicts, Verdict)

    def states(self) -> list[WorldState]:
        """The committed states waiting, within the window."""
        return self._current(self._states, WorldState)

    def ticks(self) -> list[Tick]:
        """The ticks waiting, within the window."""
        return self._current(self._ticks, Tick)

    def radio(self) -> list[RadioBatch]:
        """What the radio delivered, batches waiting."""
        return _decoded(self._hears, RadioBatch)

    def sensor_batches(self) -> list[SensorBatch]:
        """The sensor batches waiting whose ticks are all within the window; one that does not
        decode is reported as a bad message."""
        batches: list[SensorBatch] = []
        for key, data, _ in self._readings.drain():
            try:
                b = decode(data, SensorBatch)
            except IwError as e:
                self.io.bad_message(key, e)
                continue
            if self._in_window(key, max([b.tick, *(r.tick for r in b.readings)])):
                batches.append(b)
        return batches

    def _in_window(self, key: str, tick: int) -> bool:
        """Whether a tick is within the window (:mod:`iw_zenoh.ticks`); if not, a bad message."""
        why = self.window.refuse(tick, time.monotonic_ns())
        if why:
            self.io.bad_message(key, ProtocolError(why))
        return not why

    def _current(self, queue: Queue, kind: type[M]) -> list[M]:
        """The messages waiting in a bus queue whose tick is within the window; one that does not
        decode is skipped, one from too far ahead reported."""
        out = []
        for key, data, _ in queue.drain():
            try:
                msg = decode(data, kind)
            except IwError:
                continue
            if self._in_window(key, msg.tick):
                out.append(msg)
        return out


def _decoded(queue: Queue, kind: type[M]) -> list[M]:
    """The messages waiting in a bus queue; one that does not decode is skipped."""
    out = []
    for _, data, _ in queue.drain():
        try:
            out.append(decode(data, kind))
        except IwError:
            continue
    return out
