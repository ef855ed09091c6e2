"""``iwz replay FILE``: a recording back into Zenoh, with its original timing.

Control it like a live world, on the control key of the simulation it plays into:
pause, start (resume), step, seek (``at_ns``, simulation time), stop.
"""

from __future__ import annotations

import argparse
import logging
from collections.abc import Sequence
from pathlib import Path

from iw_zenoh import keys
from iw_zenoh.errors import IwError
from iw_zenoh.process.runtime import Process, start_role
from iw_zenoh.record.checksums import in_words
from iw_zenoh.record.progress import Progress
from iw_zenoh.record.reader import file_error, open_recording, print_notes
from iw_zenoh.record.replay import Player, ReplayOptions

__all__ = ["main"]

logger = logging.getLogger(__name__)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz replay``."""
    return start_role(
        argv,
        role="replay",
        description="Play a recording back into Zenoh, as if it were live (viewers and agents cannot tell).",
        epilog=(
            "Examples:\n"
            "  iwz replay recordings/demo.mcap --rate 2 --start 10 --end 25\n"
            "  iwz replay run.mcap --as-sim replay --keys 'iw/*/world/**'    (beside a live run)"
        ),
        arguments=_arguments,
        prepare=_options,
        run=_run,
    )


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="MCAP recording")
    p.add_argument("--rate", type=float, default=1.0, help="speed factor; 0 = as fast as possible (default 1)")
    p.add_argument("--start", type=float, help="simulation time to start at, seconds")
    p.add_argument("--end", type=float, help="simulation time to stop at, seconds")
    p.add_argument("--loop", action="store_true", help="start again at the end")
    p.add_argument(
        "--keys", action="append", default=[], metavar="KEYEXPR", help="play only keys matching (repeatable)"
    )
    p.add_argument(
        "--exclude", action="append", default=[], metavar="KEYEXPR", help="do not play keys matching (repeatable)"
    )
    p.add_argument("--as-sim", help="play into this simulation name (beside a live run)")
    p.add_argument("--paused", action="store_true", help="start paused; send a 'start' control to play")


def _options(args: argparse.Namespace) -> ReplayOptions:
    if args.rate < 0:
        raise ValueError("--rate must be >= 0")
    return ReplayOptions(
        rate=args.rate,
        start_ns=int(args.start * 1e9) if args.start is not None else None,
        end_ns=int(args.end * 1e9) if args.end is not None else None,
        loop=args.loop,
        include=args.keys,
        exclude=args.exclude,
        as_sim=args.as_sim,
        paused=args.paused,
    )


def _run(proc: Process, opts: ReplayOptions) -> int:
    path = Path(proc.args.file)
    try:
        with open_recording(path) as recording:
            player = Player(recording, proc.bus, opts)
            said = Progress("iwz replay")
            player.progress = said.update
            proc.bus.token(keys.alive(player.target, "replay", "replay"))
            proc.on_stop(player.stop.set)
            proc.on_stop(player.wake.set)
            skipped = f" ({len(player.skipped)} channels not simulation keys skipped)" if player.skipped else ""
            print(f"iwz replay: {path} into iw/{player.target}/ at {opts.rate:g}x{skipped}", flush=True)
            sent = player.run()
            said.done()
            print_notes("iwz replay", recording)
        print(f"iwz replay: {sent} messages played", flush=True)
    except (OSError, IwError) as e:  # not MCAP, cut off, damaged, or nothing to replay
        print(f"iwz replay: {file_error(path, e)}; check it with iwz doctor")
        return 2
    except Exception as e:  # whatever else a file's bytes may provoke
        print(f"iwz replay: {path}: {in_words(e)}; check it with iwz doctor")
        return 2
    return 0
