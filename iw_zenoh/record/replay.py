"""Playing a recording back into Zenoh: original timing or a rate, a time window, loops, key
filters, another simulation name; paused, resumed, stepped and seeked through the world control
key of the simulation it plays into, so viewers and agents use a replay as if it were live.

Times given to the player (``start_ns``, ``end_ns``, seek) are simulation times; the recording
maps them to log times with its sim-time index (or a scan of its states for a recovered file).
"""

from __future__ import annotations

import bisect
import logging
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import IO

from iw_zenoh import keys
from iw_zenoh.bus import Bus, Inbox
from iw_zenoh.errors import IwError
from iw_zenoh.messages import Control, decode, stamp_of
from iw_zenoh.record.reader import KeyFilter, RawRecord, RecordingReader, Window
from iw_zenoh.record.recording import SIM_INDEX

__all__ = ["Player", "ReplayOptions", "sim_index"]

logger = logging.getLogger(__name__)

NEVER_REPLAYED = ("control", "register")  # commands and queries belong to the live session


@dataclass
class ReplayOptions:
    """How to play.

    Attributes:
        rate: Speed factor (2.0 twice as fast); 0 means as fast as possible.
        start_ns: Simulation time to start at (None: the beginning).
        end_ns: Simulation time to stop at (None: the end).
        loop: Start again at the end.
        include: Key expressions to play (empty: every key).
        exclude: Key expressions not to play.
        as_sim: Play into this simulation name instead of the recorded one.
        paused: Start paused (a ``start`` control plays).
        hold: At the end, wait paused for a seek (or a stop) instead of returning (a viewer's timeline).
    """

    rate: float = 1.0
    start_ns: int | None = None
    end_ns: int | None = None
    loop: bool = False
    include: list[str] = field(default_factory=list)
    exclude: list[str] = field(default_factory=list)
    as_sim: str | None = None
    paused: bool = False
    hold: bool = False


def sim_index(f: IO[bytes] | RecordingReader) -> tuple[list[int], list[int], str | None]:
    """Sorted (sim times, log times) of the recording's states, and its simulation name.

    Uses the recorder's indexes when every part has one, else scans the state channels (a part
    cut off, or recovered, has none: its recorder never finished it). The recorder indexes one
    state a simulated second, so the states after its last entry (up to a second of the
    recording's tail) are read too: the last time is always the last state's.

    Raises:
        RecordingError: When the recording cannot be read.
    """
    rec = f if isinstance(f, RecordingReader) else RecordingReader(f)
    indexed = not any(p.cut_off or SIM_INDEX not in p.metadata() for p in rec.parts)
    pairs = sorted((int(k), int(v)) for k, v in rec.metadata().get(SIM_INDEX, {}).items()) if indexed else []
    sims = [p[0] for p in pairs]
    logs = [p[1] for p in pairs]
    sim_name: str | None = None
    for topic in sorted(rec.topics()):
        if keys.topic_kind(topic) == "state":
            sim_name = keys.sim_of(topic)
    for r in rec.raw(("state",), window=Window(log_start=logs[-1] if logs else None)):
        sim_name = keys.sim_of(r.topic)
        _, s = stamp_of(r.data)
        if not sims or s > sims[-1]:
            sims.append(s)
            logs.append(r.log_time)
    return sims, logs, sim_name


class Player:
    """Plays one recording.

    Args:
        stream: The recording (seekable), or a reader over it (every part of it).
        bus: Where to publish.
        opts: How.
        now_ns: Monotonic clock (injected for tests).
    """

    def __init__(
        self,
        stream: IO[bytes] | RecordingReader,
        bus: Bus,
        opts: ReplayOptions,
        now_ns: Callable[[], int] = time.monotonic_ns,
    ) -> None:
        self.recording = stream if isinstance(stream, RecordingReader) else RecordingReader(stream)
        self.bus = bus
        self.opts = opts
        self.now_ns = now_ns
        self.sims, self.logs, self.sim = sim_index(self.recording)
        if self.sim is None:
            raise IwError("the recording holds no world state: nothing to replay against")
        self.target = keys.chunk(opts.as_sim or self.sim)
        self.stop = threading.Event()
        self.wake = threading.Event()
        self.control = Inbox(wake=self.wake)
        bus.subscribe(keys.control(self.target), self.control)
        self.paused = opts.paused
        self.steps = 0  # ticks still to play paused (a step plays a state and the rest of its tick)
        self._stepping: int | None = None  # sim time of the tick a step is playing the rest of
        self.sent = 0
        self.position_ns = 0  # sim time of the last state played
        self.progress: Callable[[float, str], None] | None = None  # told how far, at each state played
        self._seek: int | None = None
        self._rate: float | None = None  # a new rate asked from another thread, taken by the player's
        self.at_end = False  # held at the end of the recording (``hold``)
        self._keys = KeyFilter(tuple(opts.include), tuple(opts.exclude))
        self._wanted_by_topic: dict[str, bool] = {}
        self._last_info: bytes | None = None
        self._base: tuple[int, int] | None = None  # (log ns, wall ns) that timing counts from
        self._info_q = bus.serve(keys.info(self.target))
        self.skipped = sorted(t for t in self.recording.topics() if keys.sim_of(t) is None)
        if self.skipped:
            logger.info("not simulation keys, not played: %s", ", ".join(self.skipped))

    def log_time_at(self, sim_ns: int) -> int:
        """The log time to start reading at to play from simulation time ``sim_ns`` (an index
        entry before it: a tick's readings may be received before its state)."""
        if not self.sims:
            return 0
        i = bisect.bisect_left(self.sims, sim_ns) - 1
        return self.logs[max(0, i)]

    @property
    def last_info(self) -> bytes | None:
        """The last world description played or passed over (what a late joiner is told)."""
        return self._last_info

    def set_rate(self, rate: float) -> None:
        """Plays at ``rate`` from now on (0: as fast as possible); safe from another thread."""
        if rate < 0:
            raise ValueError("a rate must be >= 0")
        self._rate = rate
        self.wake.set()

    def _wanted(self, key: str) -> bool:
        got = self._wanted_by_topic.get(key)
        if got is None:
            # only simulation keys, and never a derived channel (/foxglove/scene): none is a Zenoh key
            sim_key = keys.sim_of(key) is not None and keys.topic_kind(key) not in NEVER_REPLAYED
            got = self._wanted_by_topic[key] = sim_key and self._keys(key)
        return got

    def _commands(self) -> None:
        if self._rate is not None:
            self.opts.rate, self._rate = self._rate, None
            self._base = None  # time from here at the new rate
        for _, data, _ in self.control.drain():
            try:
                c = decode(data, Control)
            except IwError as e:
                logger.warning("control refused: %s", e)
                continue
            if c.command == "pause":
                self.paused = True
            elif c.command == "start":
                self.paused, self.steps = False, 0
            elif c.command == "step":
                self.paused, self.steps = True, self.steps + c.steps
            elif c.command == "seek":
                self._seek = c.at_ns
            elif c.command == "stop":
                self.stop.set()
        for q in self._info_q.poll():
            if self._last_info is not None:
                q.reply(self._last_info)

    def _messages(self, from_sim: int | None) -> Iterator[RawRecord]:
        start_log = self.log_time_at(from_sim) if from_sim is not None else None
        return self.recording.raw(window=Window(log_start=start_log))

    def run(self) -> int:
        """Plays until the end (or forever with ``loop``), ``stop``, or a stop control."""
        origin = self.opts.start_ns
        while not self.stop.is_set():
            played = self._play(origin)
            if self._seek is not None:
                origin, self._seek = self._seek, None
                continue
            if self.opts.loop and played and not self.stop.is_set():
                origin = self.opts.start_ns
                continue
            if not self.opts.hold or self._hold() is None:
                break
            origin, self._seek = self._seek, None
        return self.sent

    def _hold(self) -> int | None:
        """At the end: paused until a seek (its time) or a stop (``None``)."""
        self.paused, self.at_end = True, True
        while not self.stop.is_set() and self._seek is None:
            self.wake.wait(0.2)
            self.wake.clear()
            self._commands()
        self.at_end = False
        return self._seek

    def _pace(self, log_ns: int) -> bool:
        """Waits until ``log_ns`` is due (honouring pause and steps); False to abandon the pass."""
        while True:
            while self.paused and self.steps == 0 and not self.stop.is_set() and self._seek is None:
                self.wake.wait(0.2)
                self.wake.clear()
                self._commands()
                self._base = None  # resume with fresh timing
            if self.stop.is_set() or self._seek is not None:
                return False
            if self._base is None:
                self._base = (log_ns, self.now_ns())
            if self.opts.rate <= 0 or (self.paused and self.steps > 0):
                return True
            due = self._base[1] + int((log_ns - self._base[0]) / self.opts.rate)
            interrupted = False
            while (left := due - self.now_ns()) > 0 and not self.stop.is_set():
                if self.wake.wait(min(left / 1e9, 0.2)):
                    self.wake.clear()
                    self._commands()
                    if self.paused or self._seek is not None or self._base is None:
                        interrupted = True
                        break
            if not interrupted:
                return not self.stop.is_set()

    def _end_step(self) -> None:
        """The step under way is over (the next tick begins, or the pass ends)."""
        if self._stepping is not None:
            self._stepping = None
            self.steps = max(0, self.steps - 1)

    def _play(self, from_sim: int | None) -> bool:
        self._base = None
        self._end_step()
        skipping = from_sim is not None
        played = False
        for r in self._messages(from_sim):
            topic, data, log_ns, pub_ns = r.topic, r.data, r.log_time, r.publish_time
            self._commands()
            if self.stop.is_set() or self._seek is not None:
                return played
            kind = keys.topic_kind(topic)
            if skipping:
                # start with the tick of the first state at or after the requested time: its
                # readings and radio may have been published (and recorded) before its state
                if from_sim is not None and pub_ns >= from_sim:
                    skipping = False
                elif kind == "info":
                    self._last_info = data
                    continue
                else:
                    continue
            if self.opts.end_ns is not None and kind == "state" and pub_ns > self.opts.end_ns:
                return played
            if self._stepping is not None and (kind == "state" or pub_ns > self._stepping):
                self._end_step()  # a step plays its tick's readings and radio too, which may follow its state
            if not self._pace(log_ns):
                return played
            if kind == "info":
                self._last_info = data
            if self._wanted(topic):
                self.bus.publish(keys.with_sim(topic, self.target), data)
                self.sent += 1
                played = True
            if kind == "state":
                self.position_ns = pub_ns
                if self.progress is not None:
                    self.progress(self.recording.progress(), f"t={pub_ns / 1e9:.1f} s")
                if self.steps > 0:
                    self._stepping = pub_ns
        return played
