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
from iw_zenoh.cliargs import add_common_arguments, net_from_args
from iw_zenoh.errors import IwError
from iw_zenoh.nodes.base import NodeIO, install_stop_signals, setup_logging
from iw_zenoh.record.recording import Recorder

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
    p = argparse.ArgumentParser(
        prog="iwz record",
        description=(
            "Record every key of a simulation (iw/SIM/**) to an MCAP file: one channel per key, "
            "JSON Schemas, zstd chunks."
        ),
        epilog="Example: iwz record -o recordings/today.mcap    (Ctrl-C finishes the file)",
    )
    p.add_argument("-o", "--output", help="MCAP file to write (default recordings/SIM-DATE-TIME.mcap)")
    p.add_argument(
        "--meta",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="metadata to store (repeatable), e.g. scenario=demo",
    )
    p.add_argument("--name", default="recorder", help="instance name (liveliness)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    add_common_arguments(p)
    args = p.parse_args(argv)
    setup_logging(args.verbose, "record")
    out = Path(args.output) if args.output else default_path(args.sim)
    extra: dict[str, str] = {}
    for item in args.meta:
        k, sep, v = item.partition("=")
        if not sep or not k:
            print(f"iwz record: --meta takes KEY=VALUE, got {item!r}")
            return 2
        extra[k] = v
    try:
        bus = ZenohBus(net_from_args(args))
    except (IwError, ValueError) as e:
        print(f"iwz record: {e}")
        return 2
    io = NodeIO(bus, keys.chunk(args.sim), "recorder", args.name)
    install_stop_signals(io.stop, io.wake.set)
    print(f"iwz record: recording iw/{args.sim}/** to {out}", flush=True)
    try:
        rec = record(
            bus,
            args.sim,
            out,
            io=io,
            metadata={"iw.user": extra, "iw.versions.recorder": {"iw-zenoh": __version__}},
            status=not args.quiet,
        )
    finally:
        bus.close()
    print(f"iwz record: {sum(rec.counts.values())} messages on {len(rec.counts)} keys written to {out}", flush=True)
    return 0
