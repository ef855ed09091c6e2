"""``iwz view [RECORDING.mcap]``: the web viewer, live or replaying a recording (the page and its
server: :mod:`iw_zenoh.viewer`)."""

from __future__ import annotations

import argparse
import asyncio
import logging
import threading
from collections.abc import Sequence
from pathlib import Path

from aiohttp import web

from iw_zenoh.errors import IwError
from iw_zenoh.nodes.foxglove_live import DEFAULT_PORT as FOXGLOVE_PORT
from iw_zenoh.nodes.foxglove_live import FoxgloveLive, start_foxglove_live
from iw_zenoh.process.runtime import Process, start_role
from iw_zenoh.record.reader import file_error
from iw_zenoh.viewer.feed import Feed
from iw_zenoh.viewer.guard import Access, is_loopback
from iw_zenoh.viewer.server import MAX_PAGES, make_app
from iw_zenoh.viewer.sources import LiveSource, ReplaySource, Source

__all__ = ["main"]

logger = logging.getLogger(__name__)

EPILOG = """Examples:
  iwz run demo &  iwz view            then open http://127.0.0.1:8080/
  iwz view --port 9000 --sim hospital          a simulation named hospital, on port 9000
  iwz view --host 0.0.0.0 -e tcp/10.0.0.5:7447  the page on the LAN: only with a key (printed at start)
  iwz view recordings/demo-sample.mcap         replay a recording with a timeline (no router needed)
  iwz view --port 0                            any free port (the address is printed)
  iwz view --foxglove-port 9765                Foxglove / Lichtblick live on ws://127.0.0.1:9765
  iwz view --no-foxglove                       the page only
  iwz view --max-pages 100                     up to 100 pages at once (default 32)

A live viewer also serves the Foxglove WebSocket protocol (default
ws://127.0.0.1:8765): Foxglove or Lichtblick connects to it and sees the same
channels as in a recording (docs/foxglove.md).

On the page: drag to pan, wheel to zoom, click a robot for its panel; the
buttons start, pause, step, stop; docs/viewer.md explains every control and
the WebSocket messages.

Who gets in: on loopback (the default), this machine's pages of 127.0.0.1, localhost
and [::1] with the port, and they steer; a page of another site (its Origin), or a
foreign Host name (DNS rebinding), is refused with HTTP 403. Served anywhere else
(--host 0.0.0.0), nobody gets in without a key: two addresses are printed at start,
a WATCH one (read-only) and a STEER one (start, pause, stop, remove, obstacles).
The keys change each start (docs/viewer.md, docs/security.md)."""


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz view``."""
    args = list(argv) if argv is not None else None
    replay = any(a.endswith(".mcap") for a in (args or []))
    return start_role(
        args,
        role="viewer",
        prog="iwz view",
        description=(
            "The web viewer: a page (2D and 3D) of a live simulation, steered from the page, or of a "
            "recording with a timeline. Works offline: everything is served from the package."
        ),
        epilog=EPILOG,
        arguments=_arguments,
        prepare=_check,
        run=_run,
        default_mode="peer" if replay else "client",  # a replay needs no router
    )


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("recording", nargs="?", help="an MCAP recording to replay (default: the live simulation)")
    p.add_argument("--port", type=int, default=8080, help="HTTP port of the page (default 8080; 0: any free port)")
    p.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to serve on (default 127.0.0.1: this machine only; 0.0.0.0: the network, with keys)",
    )
    p.add_argument("--rate", type=float, default=1.0, help="replay: the speed to start at (default 1)")
    p.add_argument(
        "--foxglove-port",
        type=int,
        default=FOXGLOVE_PORT,
        help=f"live: the Foxglove WebSocket port, on --host (default {FOXGLOVE_PORT}; 0: any free port)",
    )
    p.add_argument("--no-foxglove", action="store_true", help="live: do not serve the Foxglove WebSocket protocol")
    p.add_argument(
        "--foxglove-allow-origin",
        action="append",
        default=[],
        metavar="ORIGIN",
        help="live: also let web pages of ORIGIN read Foxglove live (repeatable; docs/foxglove.md)",
    )
    p.add_argument(
        "--max-pages",
        type=int,
        default=MAX_PAGES,
        help=f"pages open at once (default {MAX_PAGES}); the next is refused with HTTP 503 until one closes",
    )


def _check(args: argparse.Namespace) -> argparse.Namespace:
    if not 0 <= args.port <= 65535:
        raise IwError(f"--port {args.port} is no TCP port: give 0..65535 (0: any free port)")
    if not 0 <= args.foxglove_port <= 65535:
        raise IwError(f"--foxglove-port {args.foxglove_port} is no TCP port: give 0..65535 (0: any free port)")
    if args.max_pages < 1:
        raise IwError(f"--max-pages {args.max_pages}: give 1 or more (pages open at once)")
    if args.rate < 0:
        raise IwError("--rate must be >= 0 (0: as fast as possible)")
    if args.recording is not None and not Path(args.recording).exists():
        raise IwError(f"{args.recording}: no such file (give an MCAP recording, e.g. recordings/demo-sample.mcap)")
    return args


def _run(proc: Process, args: argparse.Namespace) -> int:
    wake = threading.Event()
    source: Source
    if args.recording is not None:
        try:
            source = ReplaySource(Path(args.recording), wake, rate=args.rate)
        except (OSError, IwError) as e:
            print(f"iwz view: {file_error(args.recording, e)}; check it with iwz doctor", flush=True)
            return 2
    else:
        source = LiveSource(proc.bus, proc.sim, wake)
        proc.io.alive()
    fox = None if args.recording is not None or args.no_foxglove else _foxglove(proc)
    if fox is False:
        source.close()
        return 2
    try:
        return asyncio.run(_serve(proc, source, Feed(source.sim), wake))
    finally:
        if isinstance(fox, FoxgloveLive):
            fox.close()
        source.close()


def _foxglove(proc: Process) -> FoxgloveLive | bool:
    """Starts Foxglove live beside the page; False (and why, printed) when its port is taken."""
    host, port = proc.args.host, proc.args.foxglove_port
    try:
        live = start_foxglove_live(proc.io, host, port, proc.args.foxglove_allow_origin)
    except RuntimeError as e:
        print(
            f"iwz view: cannot serve Foxglove on {host}:{port}: {e}; "
            "use --foxglove-port N (0: any free port) or --no-foxglove",
            flush=True,
        )
        return False
    print(f"iwz view: Foxglove live on ws://{host}:{live.port}", flush=True)
    if not is_loopback(host):
        print(
            f"iwz view: WARNING: Foxglove on {host} has no key: anyone on the network can watch the run there "
            "(read-only: it cannot steer); --no-foxglove closes it",
            flush=True,
        )
    return live


async def _serve(proc: Process, source: Source, feed: Feed, wake: threading.Event) -> int:
    access = Access(proc.args.host)
    runner = web.AppRunner(make_app(source, feed, wake, max_pages=proc.args.max_pages, access=access), access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, proc.args.host, proc.args.port)
    try:
        await site.start()
    except OSError as e:
        await runner.cleanup()
        print(
            f"iwz view: cannot serve on {proc.args.host}:{proc.args.port}: {e.strerror or e}; "
            "is another viewer there? Use --port N (or --port 0 for any free port)",
            flush=True,
        )
        return 2
    access.port = runner.addresses[0][1] if runner.addresses else proc.args.port
    what = f"replay of {proc.args.recording}" if not source.live else f"live simulation {proc.sim!r}"
    _announce(access, what)
    try:
        await asyncio.get_running_loop().run_in_executor(None, proc.io.stop.wait)
    finally:
        await runner.cleanup()
    return 0


def _announce(access: Access, what: str) -> None:
    """Prints the page's addresses: on loopback its plain one; elsewhere, loudly, the keyed ones."""
    watch, steer = access.addresses(access.host)
    if access.local:
        print(f"iwz view: http://{access.host}:{access.port}/ ({what}); Ctrl-C stops", flush=True)
        print(f"iwz view: from another name for this machine (a tunnel), steer with {steer}", flush=True)
        return
    print(
        f"iwz view: WARNING: serving {what} on {access.host}:{access.port}, open to the network; nobody gets in "
        "without a key (they change each start; anyone with an address below has its right):",
        flush=True,
    )
    print(f"iwz view: WATCH (read-only) {watch}", flush=True)
    print(f"iwz view: STEER (start, pause, stop, remove, obstacles: operators only) {steer}", flush=True)
    print("iwz view: (with --host 0.0.0.0, put this machine's address in place of 0.0.0.0); Ctrl-C stops", flush=True)
