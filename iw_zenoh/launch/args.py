"""The arguments of ``iwz run``, what they change in the scenario, and where it records by default."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import msgspec

from iw_zenoh.core.modes import Mode
from iw_zenoh.errors import ConfigError
from iw_zenoh.scenario.fields import parse_set
from iw_zenoh.scenario.tables import Scenario, SecuritySection

__all__ = ["build_parser", "default_recording", "scenario_from_args", "scenario_sets"]


def default_recording(name: str) -> Path:
    """``recordings/NAME-DATE-TIME.mcap``."""
    return Path("recordings") / f"{name}-{time.strftime('%Y%m%d-%H%M%S')}.mcap"


EPILOG = (
    "Examples:\n"
    "  iwz run demo                        (Ctrl-C stops everything cleanly)\n"
    "  iwz run demo --secure     (every process its certificate; the router enforces the roles)\n"
    "  iwz run demo --secure --no-audit   (enforced all the same, refusals not logged)\n"
    "  iwz run lab.toml --listen tls/10.0.0.1:7447 --ids ids          (host with the router)\n"
    "  iwz run lab.toml --host laptop2 --connect tls/10.0.0.1:7447 --ids ids   (another host)\n"
    "\n"
    "Exit codes: 0 every criterion holds, 1 one fails (or the recording was not finished:\n"
    "its disk full, its recorder killed), 2 scenario or arguments refused, 3 a role could\n"
    "not start, 70 iwz run itself failed (its traceback above), 130 Ctrl-C.\n"
    "SIGTERM and SIGHUP (its terminal closed) stop the run as Ctrl-C does, with the verdict\n"
    "so far (0 or 1). Killed, it leaves nothing running: each process it started begins to\n"
    "stop by itself within half a second, and is killed if it still runs a minute later\n"
    "(docs/runtime.md, Faults)."
)


def _add_trace(p: argparse.ArgumentParser) -> None:
    """``--input-trace``: a recorded driver replayed (``--lockstep`` is among the study's arguments)."""
    p.add_argument(
        "--input-trace",
        metavar="FILE",
        help="replay this recorded input trace as the driver of every `manual` agent (docs/driving.md), e.g. "
        "iwz run slalom-manual --lockstep --input-trace maps/scenarios/slalom-manual.trace.jsonl",
    )


def build_parser() -> argparse.ArgumentParser:
    """The arguments of ``iwz run``."""
    p = argparse.ArgumentParser(
        prog="iwz run",
        description=(
            "Start a whole simulation from a scenario file: the router, world, collision, sensors, "
            "radio and every agent, each its own process on this machine."
        ),
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "scenario",
        help="a scenario TOML file, or a shipped scenario by name (iwz scenarios lists them; docs/scenarios.md)",
    )
    p.add_argument(
        "--port", type=int, default=0, help="router port on 127.0.0.1 (default 7447, or a free port if taken)"
    )
    p.add_argument("--sim", default="default", help="simulation name (default: default)")
    p.add_argument("--log-dir", help="where each process's log goes (default: a new temporary folder)")
    p.add_argument("--no-status", action="store_true", help="no live status line")
    p.add_argument("--record", metavar="FILE", help="record the run here (default recordings/SCENARIO-DATE-TIME.mcap)")
    p.add_argument("--no-record", action="store_true", help="do not record the run")
    _add_study_arguments(p)
    g = p.add_argument_group("security and several hosts (docs/security.md)")
    g.add_argument(
        "--secure",
        action="store_true",
        help="every process with an identity of its own (certificates in --ids), the router enforcing over "
        "mutual TLS what each role may do (as [security] in the scenario)",
    )
    g.add_argument(
        "--no-audit",
        dest="audit",
        action="store_false",
        help="a secured run's router enforces the policy without logging its refusals (as audit = false in "
        "the scenario's [security]; docs/security.md has what the log costs)",
    )
    g.add_argument("--ids", metavar="DIR", help="the run's identities, made there if missing (default LOG_DIR/ids)")
    g.add_argument("--host", default="", help="start only the processes [security] hosts gives this host")
    g.add_argument(
        "--connect", default="", metavar="ENDPOINT", help="the router another host runs, e.g. tls/10.0.0.1:7447"
    )
    g.add_argument("--listen", default="", metavar="ENDPOINT", help="where the router listens (default loopback)")
    p.add_argument("-v", "--verbose", action="count", default=0, help="log more")
    return p


def _add_study_arguments(p: argparse.ArgumentParser) -> None:
    """``--lockstep``, ``--seed`` and ``--set``: what one run of an ``iwz study`` changes."""
    p.add_argument("--lockstep", action="store_true", help="run in lock-step whatever the scenario says (reproducible)")
    p.add_argument(
        "--seed",
        type=int,
        metavar="N",
        help="the world's seed (the scenario's world.seed otherwise), e.g. iwz run demo --lockstep --seed 7",
    )
    p.add_argument(
        "--set",
        action="append",
        default=[],
        type=_set_arg,
        metavar="FIELD=VALUE",
        help='change a scenario field, e.g. --set world.duration_s=30 --set \'agents[0].args=["--id", "1"]\' '
        "(repeatable; VALUE as in the file; docs/study.md)",
    )
    _add_trace(p)


def _set_arg(text: str) -> tuple[str, Any]:
    try:
        return parse_set(text)
    except ConfigError as e:
        raise argparse.ArgumentTypeError(e.reason) from None


def scenario_sets(args: argparse.Namespace) -> list[tuple[str, Any]]:
    """The fields ``--set`` and ``--seed`` change, in order (``--seed`` last: it wins)."""
    return [*args.set, *([("world.seed", args.seed)] if args.seed is not None else [])]


def _with_trace(sc: Scenario, trace: Path) -> Scenario:
    """The scenario with ``trace`` replayed as the driver of every ``manual`` agent.

    Raises:
        ConfigError: The file is missing, or no agent of the scenario accepts a driver.
    """
    if not trace.is_file():
        raise ConfigError("--input-trace", f"no such file: {trace}")
    manual = [a for a in sc.agents if a.program == "manual"]
    if not manual:
        raise ConfigError("--input-trace", f"scenario {sc.name!r} has no `manual` agent to drive")
    arg = ("--input-trace", str(trace.resolve()))
    agents = tuple(msgspec.structs.replace(a, args=(*a.args, *arg)) if a in manual else a for a in sc.agents)
    return msgspec.structs.replace(sc, agents=agents)


def scenario_from_args(sc: Scenario, args: argparse.Namespace) -> Scenario:
    """The scenario as ``iwz run``'s options change it: ``--lockstep`` its mode, ``--no-audit``
    its ``[security] audit``, ``--input-trace`` its ``manual`` agents' driver.

    Args:
        sc: The scenario as its file says.
        args: ``iwz run``'s parsed arguments.

    Returns:
        The scenario to run.

    Raises:
        ConfigError: ``--no-audit`` for a run that is not secured (no router log to turn off).
    """
    replace = msgspec.structs.replace
    if args.lockstep:
        sc = replace(sc, world=replace(sc.world, mode=Mode.LOCKSTEP))
    if getattr(args, "input_trace", None):
        sc = _with_trace(sc, Path(args.input_trace))
    if not args.audit:
        if not (args.secure or (sc.security is not None and sc.security.enabled)):
            raise ConfigError(
                "--no-audit",
                "only a secured run's router logs refusals: add --secure (or [security] to the scenario), "
                "or leave --no-audit out",
            )
        sc = replace(sc, security=replace(sc.security or SecuritySection(enabled=args.secure), audit=False))
    return sc
