"""``iwz record [-o FILE]``: every key of a simulation, every message, to MCAP.

Receives into an unbounded queue (Zenoh's callback only appends) and writes from its own loop;
closes a chunk at least once a second; on Ctrl-C or SIGTERM writes what is queued, the indexes
and the counts, and exits 0.
"""

from __future__ import annotations

import argparse
import logging
import platform
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from iw_zenoh import __version__, keys
from iw_zenoh.bus import ZenohBus
from iw_zenoh.record.recording import Recorder
from iw_zenoh.runtime import NodeIO, Process, start_role

__all__ = ["default_path", "main", "record"]

logger = logging.getLogger(__name__)

FLUSH_S = 1.0  # a kill -9 loses at most this much
POLL_S = 0.005  # an empty queue is looked at again this soon
QUIET_S = 0.5  # on stop, keep writing until the bus has been quiet this long...
DRAIN_MAX_S = 30.0  # ...but no longer than this


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
) -> Recorder:
    """Records until ``io.stop`` is set; returns the finished recorder (its counts)."""
    inbox = bus.queue(keys.everything(sim))  # lossless: Zenoh holds senders back when it is full
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("wb") as f:
        meta = {
            "iw.run": {
                "sim": sim,
                "host": platform.node(),
                "python": sys.version.split()[0],
                "started_ns": str(time.time_ns()),
            }
        }
        meta.update(metadata or {})
        rec = Recorder(f, meta)
        io.alive()
        last_flush = time.monotonic()
        last_status = last_flush
        stop_at: float | None = None
        last_msg = time.monotonic()
        while True:
            if io.stop.is_set() and stop_at is None:
                stop_at = time.monotonic()
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
                    f"iwz record: {sum(rec.counts.values())} messages on {len(rec.counts)} keys, "
                    f"{rec.bytes / 1e6:.1f} MB",
                    flush=True,
                )
            # after a stop, what is still in flight towards us is part of the run: write it too
            if stop_at is not None and (now - last_msg >= QUIET_S or now - stop_at >= DRAIN_MAX_S):
                break
            if not got:
                io.stop.wait(POLL_S)
        rec.finish({"iw.received": {k: str(v) for k, v in sorted(rec.counts.items())}})
    return rec


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
        epilog="Example (Ctrl-C finishes the file):\n  iwz record -o recordings/today.mcap --meta scenario=demo",
        arguments=_arguments,
        prepare=_prepare,
        run=_run,
    )


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("-o", "--output", help="MCAP file to write (default recordings/SIM-DATE-TIME.mcap)")
    p.add_argument(
        "--meta",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="metadata to store (repeatable), e.g. scenario=demo",
    )
    p.add_argument("--quiet", action="store_true", help="no progress lines")


def _prepare(args: argparse.Namespace) -> tuple[Path, dict[str, str]]:
    """Where to write and the user's metadata."""
    extra: dict[str, str] = {}
    for item in args.meta:
        k, sep, v = item.partition("=")
        if not sep or not k:
            raise ValueError(f"--meta takes KEY=VALUE, got {item!r}")
        extra[k] = v
    return (Path(args.output) if args.output else default_path(args.sim)), extra


def _run(proc: Process, target: tuple[Path, dict[str, str]]) -> None:
    out, extra = target
    print(f"iwz record: recording iw/{proc.sim}/** to {out}", flush=True)
    rec = record(
        proc.bus,
        proc.sim,
        out,
        io=proc.io,
        metadata={"iw.user": extra, "iw.versions.recorder": {"iw-zenoh": __version__}},
        status=not proc.args.quiet,
    )
    print(f"iwz record: {sum(rec.counts.values())} messages on {len(rec.counts)} keys written to {out}", flush=True)
