"""``iwz agent NAME [options]``: runs agents of the program NAME (a module of ``iw_zenoh.agents``
with ``add_arguments(parser)`` and ``make(args) -> list[Agent]``) in one process."""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import pkgutil
from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.agent import BATCH_FROM, Agent, AgentHost, RegistrationRefused
from iw_zenoh.runtime import Process, start_role

__all__ = ["available", "main"]

logger = logging.getLogger(__name__)


def available() -> list[str]:
    """Names of the agent programs that ship."""
    package = importlib.import_module("iw_zenoh.agents")
    names = sorted(m.name for m in pkgutil.iter_modules(package.__path__) if not m.name.startswith("_"))
    # helper modules (the autopilot, the emulated chair) are not programs: a program has make()
    return [n for n in names if hasattr(importlib.import_module(f"iw_zenoh.agents.{n}"), "make")]


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz agent NAME``."""
    argv = list(argv or [])
    names = available()
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: iwz agent NAME [options]\n\nRuns agent programs over Zenoh. Programs: " + ", ".join(names))
        print("Options of one program: iwz agent NAME --help")
        return 0 if argv else 2
    name, rest = argv[0], argv[1:]
    if name not in names:
        print(f"iwz agent: no agent program {name!r}; choose one of {', '.join(names)}")
        return 2
    module = importlib.import_module(f"iw_zenoh.agents.{name}")

    def arguments(p: argparse.ArgumentParser) -> None:
        module.add_arguments(p)
        p.add_argument(
            "--batch",
            choices=["auto", "on", "off"],
            default="auto",
            help=(
                "read sensor batches and answer all robots in one message a tick (auto: when hosting "
                f"{BATCH_FROM} robots or more; off: each robot's own keys)"
            ),
        )

    return start_role(
        rest,
        role="agent",
        prog=f"iwz agent {name}",
        description=" ".join((module.__doc__ or "").strip().split("\n\n")[0].split()),
        epilog=(
            "Examples:\n"
            f"  maps/*.toml          the [[agents]] tables with program = {name!r}, at work in a scenario\n"
            "  docs/agents.md       every program, the planner and the door protocol\n"
            "  iwz agent --help     the other programs"
        ),
        arguments=arguments,
        prepare=module.make,
        run=_host,
        name=lambda _args: f"{name}-{os.getpid()}",
        name_help="NAME-PID",
    )


def _host(proc: Process, agents: list[Agent]) -> int:
    """Registers every agent, then runs them until stopped."""
    batch = proc.args.batch
    batched = batch == "on" or (batch == "auto" and len(agents) >= BATCH_FROM)
    host = AgentHost(proc.bus, proc.sim, keys.chunk(proc.name), batched=batched, io=proc.io)
    try:
        for a in agents:
            attach_to = getattr(a, "attach_to", 0)  # a robot another process registered (a serial bridge)
            rid = host.attach(a, attach_to) if attach_to else host.add(a)
            logger.info("robot %d registered for %s", rid, a.spec().name)
        host.run()
    except RegistrationRefused as e:
        print(f"{proc.prog}: registration refused: {e}")
        return 3
    return 0
