"""``iwz record [-o FILE]``: every key of a simulation, every message, to MCAP.

Receives into an unbounded queue (Zenoh's callback only appends) and writes from its own loop;
closes a chunk at least four times a second; on Ctrl-C or SIGTERM writes what is queued and what
is still in flight (until the bus is quiet, at most 30 s), the indexes and the counts, and exits 0;
a second Ctrl-C (SIGINT, SIGTERM or SIGHUP) finishes the file at once, with what has arrived.
With ``--continue`` (the launcher passes it, with its run's id), a recorder restarted after a
crash writes the next part of the same recording (``run.part2.mcap``...:
:mod:`iw_zenoh.record.parts`) instead of overwriting it; it listens before it opens its file, so
what arrives while it starts is kept. A file it cannot write (the disk full, the device gone) ends
it with one line that says why and what of the file is kept, and exit :data:`CANNOT_WRITE` (4),
which ``iwz run`` does not restart: a new part on the same full disk would be empty.

Every file (a fresh one, a continued part, a recorder started beside a running simulation) is
self-contained: the recorder asks the world for its description (``world/info``: the lab and its
walls, the robots' accepted specs, the revision) as it opens the file, and records the answer on
``world/info`` as if published then, so the scene, the transforms and ``iwz render`` have what
they draw with from the part's start.
"""

from __future__ import annotations

import logging
import platform
import signal
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING

from iw_zenoh import __version__, keys
from iw_zenoh.bus import Asked, Queue, ZenohBus
from iw_zenoh.nodes.role_options import RecorderOptions, add_recorder_arguments
from iw_zenoh.process.options import options_from_args
from iw_zenoh.process.runtime import NodeIO, Process, start_role
from iw_zenoh.record.parts import PART_META, next_part

if TYPE_CHECKING:
    from iw_zenoh.record.recording import Recorder

__all__ = ["CANNOT_WRITE", "CannotWrite", "default_path", "main", "record"]

logger = logging.getLogger(__name__)

FLUSH_S = 0.25  # a kill -9 loses at most this much (with a restart, the budget is 1 s in all)
POLL_S = 0.005  # an empty queue is looked at again this soon
QUIET_S = 0.5  # on stop, keep writing until the bus has been quiet this long...
DRAIN_MAX_S = 30.0  # ...but no longer than this
CANNOT_WRITE = 4  # the exit code of a recorder that cannot write its file
INFO_TIMEOUT_S = 5.0  # how long the world's description is waited for (the recording goes on meanwhile)


class CannotWrite(Exception):
    """The recording's file cannot be written (its message says which, why and what is kept)."""


def default_path(sim: str) -> Path:
    """``recordings/SIM-YYYYmmdd-HHMMSS.mcap``."""
    return Path("recordings") / f"{sim}-{time.strftime('%Y%m%d-%H%M%S')}.mcap"


def record(
    bus: ZenohBus,
    sim: str,
    out: Path,
    *,
    io: NodeIO,
    metadata: dict[str, dict[str, str]] | None = None,
    status: bool = False,
    continue_run: str | None = None,
) -> tuple[Path, Recorder]:
    """Records until ``io.stop`` is set.

    Args:
        bus: Where to listen.
        sim: The simulation to record (``iw/SIM/**``).
        out: The recording (its first part).
        io: The process's stop event and liveliness.
        metadata: Named string maps to store.
        status: Print a progress line every 5 s.
        continue_run: ``None`` to write ``out`` afresh; else continue the recording there, when
            it is this one (see :func:`iw_zenoh.record.parts.next_part`), in its next part.

    Returns:
        The file written (``out``, or the part it continued into) and the finished recorder.
    """
    inbox = bus.queue(keys.everything(sim))  # lossless: Zenoh holds senders back when it is full
    # only now: the writer's scene drawing loads numpy and shapely (slow to import), and a restarted
    # recorder must be listening as soon as it can; what arrives meanwhile waits in the queue
    from iw_zenoh.record.recording import Recorder  # noqa: PLC0415

    out.parent.mkdir(parents=True, exist_ok=True)
    path, part, user = next_part(out, continue_run)  # what arrives meanwhile waits in the queue
    meta = {
        "iw.run": {
            "sim": sim,
            "host": platform.node(),
            "python": sys.version.split()[0],
            "started_ns": str(time.time_ns()),
        },
        PART_META: part,
    }
    meta.update(metadata or {})
    if user and not meta.get("iw.user"):
        meta["iw.user"] = user  # a continuation carries the recording's scenario, seed and map
    which = f" (part {part['part']}, after {part['previous']})" if part["previous"] else ""
    print(f"iwz record: recording iw/{sim}/** to {path}{which}", flush=True)
    rec: Recorder | None = None
    try:
        with path.open("wb") as f:
            rec = Recorder(f, meta)
            asked = bus.ask(keys.info(sim), timeout_s=INFO_TIMEOUT_S)  # the part's own description
            io.alive()
            _write(rec, inbox, f, io, status, _Described(keys.info(sim), asked))
            rec.finish({"iw.received": {k: str(v) for k, v in sorted(rec.counts.items())}})
    except OSError as e:
        raise CannotWrite(_cannot_write(path, e, rec)) from None
    return path, rec


def _cannot_write(path: Path, e: OSError, rec: Recorder | None) -> str:
    """What to say when ``path`` cannot be written: why, and what of it is kept."""
    why = e.strerror or str(e)
    if rec is None or not rec.counts:
        return f"cannot write {path}: {why}; nothing was recorded. Free space there, or record elsewhere (-o)"
    return (
        f"cannot write {path}: {why}, after {sum(rec.counts.values())} messages "
        f"({rec.bytes / 1e6:.1f} MB); the recording stops there. The file is cut off: `iwz recover {path}` "
        "makes what was written readable, once there is space for its copy"
    )


class _Described:
    """The world's answers to the recorder's question, written on ``world/info`` as they come."""

    def __init__(self, key: str, asked: Asked) -> None:
        self.key = key
        self.asked = asked
        self.taken = 0

    def write(self, rec: Recorder) -> None:
        """Records the answers that came since the last call."""
        replies = self.asked.replies[self.taken :]  # appended by the network's thread
        self.taken += len(replies)
        for data in replies:
            rec.add(self.key, data, time.time_ns())


def _write(rec: Recorder, inbox: Queue, f: IO[bytes], io: NodeIO, status: bool, described: _Described) -> None:
    """Writes what arrives until a stop, and what is still in flight after it."""
    last_flush = time.monotonic()
    last_status = last_flush
    stop_at: float | None = None
    last_msg = time.monotonic()
    at_once = threading.Event()
    while True:
        if io.stop.is_set() and stop_at is None:
            stop_at = time.monotonic()
            _finish_at_next_signal(at_once)
        described.write(rec)
        got = inbox.drain()
        for key, data, t in got:
            rec.add(key, data, t)
        if got:
            last_msg = time.monotonic()
        now = time.monotonic()
        if now - last_flush >= FLUSH_S:
            rec.flush()
            f.flush()
            last_flush = now
        if status and now - last_status >= 5.0:
            last_status = now
            print(
                f"iwz record: {sum(rec.counts.values())} messages on {len(rec.counts)} keys, {rec.bytes / 1e6:.1f} MB",
                flush=True,
            )
        # after a stop, what is still in flight towards us is part of the run: write it too
        if stop_at is not None and (now - last_msg >= QUIET_S or now - stop_at >= DRAIN_MAX_S or at_once.is_set()):
            break
        if not got:
            io.stop.wait(POLL_S)


def _finish_at_next_signal(at_once: threading.Event) -> None:
    """Once stopping: a second SIGINT, SIGTERM or SIGHUP sets ``at_once`` (the file is finished
    with what has arrived). Beside a simulation that goes on, the bus is never quiet, so the
    drain after a stop lasts its whole :data:`DRAIN_MAX_S`: says so, and how to cut it short."""
    if threading.current_thread() is not threading.main_thread():
        return  # only the main thread may set handlers (record() called from a test's thread)

    def handler(_signum: int, _frame: object) -> None:
        at_once.set()

    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, handler)
    print(
        f"iwz record: stopping: writing what is still in flight (until the bus is quiet "
        f"{QUIET_S:g} s, at most {DRAIN_MAX_S:g} s); Ctrl-C again to finish the file now",
        flush=True,
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz record``."""
    return start_role(
        argv,
        role="recorder",
        prog="iwz record",
        description=(
            "Record every key of a simulation (iw/SIM/**) to an MCAP file: one channel per key, "
            "JSON Schemas, zstd chunks."
        ),
        epilog=(
            "Ctrl-C finishes the file; beside a run that goes on, it first writes what is in flight, "
            "up to 30 s: Ctrl-C again to finish it at once.\n\n"
            "Examples:\n"
            "  iwz record -o recordings/today.mcap --meta scenario=demo\n"
            '  iwz record --options \'{"output": "run.mcap", "meta": {"scenario": "demo"}, "continue_run": "RUN"}\''
            "    (as iwz run starts it)"
        ),
        arguments=add_recorder_arguments,
        prepare=lambda args: options_from_args(args, RecorderOptions),
        run=_run,
    )


def _run(proc: Process, opts: RecorderOptions) -> int:
    try:
        path, rec = record(
            proc.bus,
            proc.sim,
            Path(opts.output) if opts.output else default_path(proc.sim),
            io=proc.io,
            metadata={"iw.user": dict(opts.meta), "iw.versions.recorder": {"iw-zenoh": __version__}},
            status=not opts.quiet,
            continue_run=opts.continue_run,
        )
    except CannotWrite as e:
        print(f"iwz record: {e}", flush=True)
        return CANNOT_WRITE
    print(f"iwz record: {sum(rec.counts.values())} messages on {len(rec.counts)} keys written to {path}", flush=True)
    return 0
