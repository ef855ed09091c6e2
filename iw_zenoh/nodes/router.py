"""``iwz router``: the Zenoh router every other process connects to (no zenohd binary needed).

Default: listens on tcp/127.0.0.1:7447 only, multicast scouting off. For several laptops:
``iwz router --listen tcp/0.0.0.0:7447`` on one, ``--connect tcp/HOST:7447`` on the others.
Secured (docs/security.md): ``--identity DIR/router --policy POLICY.toml``: mutual TLS only, the
policy's access control (default deny), and every refused message logged with who and which key.
"""

from __future__ import annotations

import argparse
import contextlib
import fcntl
import logging
import os
import threading
import time
from collections.abc import Sequence

import json5
import zenoh

from iw_zenoh.process.runtime import Process, start_role
from iw_zenoh.secure.denials import DenialLog

__all__ = ["main"]

logger = logging.getLogger(__name__)

# Zenoh logs access-control decisions at trace level only; errors of everything else
ZENOH_LOG = "error,zenoh::net::routing::interceptor::access_control=trace"
PIPE_BYTES = 1 << 20  # the pipe Zenoh's log goes through: a batch of its lines fits
BATCH_S = 0.02  # a refusal is reported at most this late


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz router`` until Ctrl-C or SIGTERM."""
    return start_role(
        argv,
        role="router",
        description=(
            "A Zenoh router for the simulation's processes (loopback only unless --listen says otherwise). "
            "With --identity and --policy it admits only mutual-TLS clients holding a certificate of the "
            "policy's authority and lets each do only what its role may (docs/security.md)."
        ),
        epilog=(
            "Examples:\n"
            "  iwz router                                   (tcp/127.0.0.1:7447)\n"
            "  iwz router --listen tcp/0.0.0.0:7447         (serve a LAN, unsecured)\n"
            "  iwz router --zenoh-config router.json5       (its listen endpoints stand; flags given replace them)\n"
            "  iwz router --identity ids/router --policy policy.toml --listen tls/0.0.0.0:7447\n"
            "  iwz router --identity ids/router --policy policy.toml --no-audit   (refusals enforced, not logged)"
        ),
        arguments=_arguments,
        prepare=_prepare,
        run=_serve,
        default_mode="router",
    )


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--policy",
        dest="security_policy",  # not "policy": an agent's own --policy (the door's) must not read as this
        metavar="TOML",
        help="a security policy (docs/security.md): who may publish, ask and answer what; needs --identity",
    )
    p.add_argument(
        "--no-audit",
        dest="audit",
        action="store_false",
        help="enforce the policy but do not log refusals (spares reading Zenoh's per-message "
        "access-control log; docs/security.md gives what each costs)",
    )


def _prepare(args: argparse.Namespace) -> None:
    if args.audit and ((args.security_policy and args.identity) or _enforces(args.zenoh_config)):
        _report_denials()


def _enforces(config_file: str | None) -> bool:
    """Whether a Zenoh configuration file turns access control on (``iwz secure config`` writes one)."""
    if not config_file:
        return False
    try:
        with open(config_file, encoding="utf-8") as f:
            doc = json5.load(f)
    except (OSError, ValueError):
        return False  # joining the bus says what is wrong with it
    acl = doc.get("access_control") if isinstance(doc, dict) else None
    return isinstance(acl, dict) and bool(acl.get("enabled"))


def _report_denials() -> None:
    """Reads Zenoh's access-control log (it writes to standard output) and prints each refusal
    with who and which key; every other line passes unchanged."""
    os.environ.setdefault("NO_COLOR", "1")  # a line per message allowed: a third shorter without colours
    zenoh.init_log_from_env_or(ZENOH_LOG)
    read, write = os.pipe()
    with contextlib.suppress(OSError, AttributeError):  # Linux: room for a batch of lines (below)
        fcntl.fcntl(write, fcntl.F_SETPIPE_SZ, PIPE_BYTES)
    out = os.dup(1)
    os.dup2(write, 1)
    os.close(write)
    threading.Thread(target=_pump, args=(read, out), name="denials", daemon=True).start()


def _pump(read: int, out: int) -> None:
    """Zenoh writes a line per message it lets through: read them in batches, every BATCH_S at
    most, so that its writes land in the pipe without waking this thread each time."""
    log = DenialLog()
    rest = b""
    while chunk := os.read(read, PIPE_BYTES):
        data = rest + chunk
        cut = data.rfind(b"\n") + 1
        block, rest = data[:cut], data[cut:]
        other, denials = log.read(block, time.monotonic_ns())
        report = b"".join(f"iwz router: {d}\n".encode() for d in denials)
        if other or report:
            os.write(out, other + report)
        if len(chunk) < PIPE_BYTES // 2:
            time.sleep(BATCH_S)


def _serve(proc: Process, _: None = None) -> None:
    proc.io.alive()
    secured = " (access control by policy)" if proc.args.security_policy or _enforces(proc.args.zenoh_config) else ""
    print(f"iwz router: listening on {', '.join(proc.bus.listening)}{secured}", flush=True)
    while not proc.io.stop.is_set():
        proc.io.stop.wait(1.0)
