"""A recording part written for the tests: ticks, a run name, cut or whole."""

from __future__ import annotations

from pathlib import Path

from iw_zenoh import keys
from iw_zenoh.messages import Event, EventKind, encode
from iw_zenoh.record.parts import (
    PART_META,
    next_part,
)
from iw_zenoh.record.recording import Recorder
from tests.support.recordings import recorded_state as _state

T0 = 1_000_000_000


def recorded_part(first: Path, ticks: range, *, run: str | None, cut: bool = False) -> Path:
    """Writes the next part as the recorder does (ticks 100 ms apart); ``cut``: killed mid-chunk."""
    path, part, user = next_part(first, run)
    meta = {PART_META: part, "iw.user": user or {"scenario": "unit", "seed": "7"}}
    f = path.open("wb")
    rec = Recorder(f, meta, chunk_size=1500, scene=False)
    for t in ticks:
        at = T0 + t * 100_000_000
        rec.add(keys.state("s"), _state(t), at)
        if t % 10 == 5:
            rec.add(
                keys.event("s", "collision"),
                encode(Event(kind=EventKind.COLLISION, robot_id=1, reason="wall", sim_time_ns=t * 10**8)),
                at + 1,
            )
    if cut:
        rec.flush()
        f.flush()
        size = f.tell()
        f.close()
        path.write_bytes(path.read_bytes()[: size - 300])  # the last chunk half written
    else:
        rec.finish()
        f.close()
    return path
