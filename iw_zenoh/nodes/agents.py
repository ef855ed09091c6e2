"""``iwz agent PROGRAM [options]``: runs the agents of one program in one process: a program
that ships (a module of ``iw_zenoh.agents`` with ``add_arguments(parser)`` and ``make(args) ->
list[Agent]``) or one from the user's own file (``./my_agent.py[:Name]``, see
:mod:`iw_zenoh.agent.programs` and ``docs/first-agent.md``)."""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Sequence

from iw_zenoh import keys
from iw_zenoh.agent import BATCH_FROM, Agent, AgentHost, RegistrationRefused
from iw_zenoh.agent.hooks import attached_to
from iw_zenoh.agent.programs import (
    ProgramError,
    add_seed_argument,
    add_spec_arguments,
    available,
    find_program,
    make_with_spec,
    program_label,
)
from iw_zenoh.process.runtime import Process, start_role

__all__ = ["available", "main"]

logger = logging.getLogger(__name__)


def _usage(names: list[str]) -> str:
    return (
        "usage: iwz agent PROGRAM [options]\n\n"
        "Runs agent programs over Zenoh. PROGRAM is one that ships, or your own file:\n"
        f"  programs: {', '.join(names)}\n"
        "  your own: ./my_agent.py (its make(args)) or ./my_agent.py:Name (an agent class, an agent,\n"
        "            or a function that returns agents); see docs/first-agent.md\n\n"
        "Examples:\n"
        "  iwz agent waypoint --waypoints '16,5.55;21.5,6.5' --id 1\n"
        "  iwz agent ./my_agent.py:GoTo --goal 10.5,3\n"
        "  iwz agent waypoint --waypoints 20,6.1 --spec maps/chair.toml   # the chair from a spec file\n\n"
        "Options of one program: iwz agent PROGRAM --help"
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz agent PROGRAM``."""
    argv = list(argv or [])
    if not argv or argv[0] in ("-h", "--help"):
        print(_usage(available()))
        return 0 if argv else 2
    name, rest = argv[0], argv[1:]
    try:
        program = find_program(name)
    except ProgramError as e:
        print(f"iwz agent: {e}", file=sys.stderr, flush=True)
        return 2

    def arguments(p: argparse.ArgumentParser) -> None:
        program.add_arguments(p)
        add_spec_arguments(p)
        add_seed_argument(p)
        p.add_argument(
            "--batch",
            choices=["auto", "on", "off"],
            default="auto",
            help=(
                "read sensor batches and answer all robots in one message a tick (auto: when hosting "
                f"{BATCH_FROM} robots or more; off: each robot's own keys)"
            ),
        )

    label = "your own program" if program.from_file else f"program = {name!r}"
    return start_role(
        rest,
        role="agent",
        prog=f"iwz agent {name}",
        description=" ".join(program.doc.strip().split("\n\n")[0].split()),
        epilog=(
            "Examples:\n"
            f"  maps/*.toml          the [[agents]] tables with {label}, at work in a scenario\n"
            "  docs/agents.md       every program, the planner and the door protocol\n"
            "  docs/first-agent.md  an agent of your own, from nothing to a chair at its goal\n"
            "  iwz agent --help     the other programs"
        ),
        arguments=arguments,
        prepare=lambda args: make_with_spec(program, args),
        run=_host,
        name=lambda _args: f"{program_label(name)}-{os.getpid()}",
        name_help="PROGRAM-PID",
    )


def _host(proc: Process, agents: list[Agent]) -> int:
    """Registers every agent, then runs them until stopped."""
    batch = proc.args.batch
    batched = batch == "on" or (batch == "auto" and len(agents) >= BATCH_FROM)
    host = AgentHost(proc.bus, proc.sim, keys.chunk(proc.name), batched=batched, io=proc.io)
    try:
        for a in agents:
            attach_to = attached_to(a)  # a robot another process registered (a serial bridge)
            rid = host.attach(a, attach_to) if attach_to else host.add(a)
            logger.info("robot %d registered for %s", rid, a.spec().name)
        host.run()
    except RegistrationRefused as e:
        print(f"{proc.prog}: registration refused: {e}")
        return 3
    return 0
