"""The player's seek and step go by ticks: a step plays a state and the rest of its tick (its
readings and radio may be recorded before or after the state), a seek starts with the tick sought."""

from __future__ import annotations

import threading
import time
from pathlib import Path

from iw_zenoh import keys
from iw_zenoh.bus import Inbox
from iw_zenoh.messages import Control, Event, EventKind, encode, stamp_of
from iw_zenoh.record.reader import open_recording
from iw_zenoh.record.recording import Recorder
from iw_zenoh.record.replay import Player, ReplayOptions
from iw_zenoh.viewer.sources import LocalBus
from tests.support.recordings import recorded_state as _state

T0 = 1_000_000_000
PERIOD = 100_000_000


def _recording(path: Path, ticks: int) -> None:
    """States 100 ms apart, each tick with one event: an odd tick's before its state, an even one's after."""
    with path.open("wb") as f:
        rec = Recorder(f, chunk_size=1500, scene=False)
        for t in range(1, ticks + 1):
            at = T0 + t * PERIOD
            ev = encode(Event(kind=EventKind.COLLISION, robot_id=1, tick=t, sim_time_ns=t * PERIOD))
            rec.add(keys.event("s", "collision"), ev, at if t % 2 else at + 2)
            rec.add(keys.state("s"), _state(t), at + 1)
        rec.finish()


def _played(out: Inbox, got: list[tuple[str, int]], want: int, timeout_s: float = 30.0) -> None:
    """Waits until ``want`` messages were played, each as (kind, tick), into ``got``."""
    deadline = time.monotonic() + timeout_s
    while len(got) < want:
        assert time.monotonic() < deadline, f"played only {got}"
        out.wait(0.05)
        got += [(str(keys.topic_kind(k)), stamp_of(d)[0]) for k, d, _ in out.drain()]


def test_a_paused_replay_seeks_to_a_whole_tick_and_steps_one_whole_tick_at_a_time(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    _recording(path, 30)
    out = Inbox()
    with open_recording(path) as rec:
        player = Player(rec, LocalBus(out), ReplayOptions(rate=1, paused=True))
        thread = threading.Thread(target=player.run)
        thread.start()
        got: list[tuple[str, int]] = []

        def ask(c: Control, then: int) -> None:
            player.control.put((keys.control("s"), encode(c), 0))
            player.wake.set()
            _played(out, got, then)

        try:
            player.control.put((keys.control("s"), encode(Control(command="seek", at_ns=11 * PERIOD)), 0))
            ask(Control(command="step"), 2)  # shows tick 11, its event (recorded before its state) too
            ask(Control(command="step"), 4)
            ask(Control(command="step"), 6)
        finally:
            player.stop.set()
            player.wake.set()
            thread.join(10)
        got += [(str(keys.topic_kind(k)), stamp_of(d)[0]) for k, d, _ in out.drain()]
    assert got == [("event", 11), ("state", 11), ("state", 12), ("event", 12), ("event", 13), ("state", 13)]
    assert player.position_ns == 13 * PERIOD
