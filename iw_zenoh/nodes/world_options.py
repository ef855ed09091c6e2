"""The options of ``iwz world`` (a msgspec Struct) and the flags that fill it.

Apart from the world process itself so that ``iwz run`` builds a world's options from a scenario
(from a scenario's typed ``[world]`` table) without the world's loop.
"""

from __future__ import annotations

import argparse
from typing import Annotated

import msgspec

from iw_zenoh.errors import IwError
from iw_zenoh.launch.secure_run import SERIAL_BRIDGE, agent_name, asked_id
from iw_zenoh.messages import Obstacle
from iw_zenoh.process.options import add_option_flags, declared_flags, option
from iw_zenoh.scenario.tables import DURATION_S_MAX, Scenario
from iw_zenoh.secure.policy import load_policy, owners
from iw_zenoh.sim.config import WorldConfig, WorldSettings
from iw_zenoh.sim.resume import WorldSnapshot

__all__ = ["WorldOptions", "add_arguments", "parse_obstacle", "world_options"]

_CORE = WorldConfig()  # the world core's defaults are the options' defaults


def parse_obstacle(text: str) -> Obstacle:
    """Parses ``NAME:X0,Y0,X1,Y1[,H]``.

    Raises:
        ValueError: Saying what the form is.
    """
    name, sep, rest = text.partition(":")
    try:
        v = [float(x) for x in rest.split(",")]
    except ValueError:
        v = []
    if not sep or not name or len(v) not in (4, 5):
        raise ValueError(f"--obstacle takes NAME:X0,Y0,X1,Y1[,HEIGHT], got {text!r}")
    return Obstacle(name=name, x0=v[0], y0=v[1], x1=v[2], y1=v[3], height=v[4] if len(v) == 5 else 1.0)


def _owners_flag(path: str) -> dict[str, list[int] | None]:
    try:
        return {a: None if r is None else list(r) for a, r in owners(load_policy(path)).items()}
    except IwError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _obstacle_flag(text: str) -> Obstacle:
    try:
        return parse_obstacle(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


class WorldOptions(WorldSettings, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """How ``iwz world`` runs: filled by its flags, or whole by ``--options JSON`` (``iwz run``).

    :class:`~iw_zenoh.sim.config.WorldSettings` (the settings a scenario's ``[world]`` shares,
    declared there once) and what only the process has.

    Attributes:
        map: Lab XML file (Ciber-Rato / Intellwheels).
        grid: Grid XML file of start positions ("": none; robots then give X and Y).
        expect: Robots to wait for before the first tick.
        duration_s: Stop after this many simulated seconds (0: run until stopped).
        obstacles: Rectangular obstacles placed before the first tick.
        owners: A secured run's agents and the robots each may register (from ``--policy``;
            ``None`` for a bridge: any); None: every agent registers any robot.
        reserved: The ids a scenario gives its agents (``--id``), by agent name: no one else
            takes them by asking for any id (``iwz run`` sets it); None: none.
        resume: Go on from this last committed state (``iwz run`` restarting a world that died;
            its obstacles replace ``obstacles``); None: a new run.
    """

    map: str = ""
    grid: Annotated[
        str,
        msgspec.Meta(
            description="Grid XML file of start positions (default: none; robots give X, Y)", extra={"metavar": "FILE"}
        ),
    ] = ""
    expect: Annotated[
        int,
        msgspec.Meta(
            description="wait for this many robots before the first tick (default {default})", extra={"metavar": "N"}
        ),
    ] = _CORE.expect
    duration_s: Annotated[
        float,
        msgspec.Meta(
            ge=0,
            le=DURATION_S_MAX,
            description="stop after this many simulated seconds (default: run until stopped)",
            extra={"flag": "--duration", "metavar": "S"},
        ),
    ] = 0.0
    obstacles: Annotated[
        tuple[Obstacle, ...],
        msgspec.Meta(
            description="a rectangular obstacle from the start (repeatable)",
            extra={"flag": "--obstacle", "action": "append", "type": _obstacle_flag, "metavar": "NAME:X0,Y0,X1,Y1[,H]"},
        ),
    ] = ()
    owners: Annotated[
        dict[str, list[int] | None] | None,
        msgspec.Meta(
            description="a secured run's policy: each agent registers only its own robots, and only under its own name",
            extra={"flag": "--policy", "type": _owners_flag, "metavar": "TOML"},
        ),
    ] = None
    resume: WorldSnapshot | None = None
    reserved: dict[str, list[int]] | None = None


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Adds the flags of ``iwz world``, each filling a field of :class:`WorldOptions`.

    The flags are generated from the fields (their ``msgspec.Meta``: help, range, spelling), so
    a new option is one line in :class:`~iw_zenoh.sim.config.WorldSettings` or here. A flag not
    given leaves its field to ``--options`` or the default (``argparse.SUPPRESS``).
    """
    p.add_argument(
        option("map"),
        nargs="?",
        metavar="MAP",
        default=argparse.SUPPRESS,
        help="Lab XML file (Ciber-Rato / Intellwheels)",
    )
    add_option_flags(p, WorldOptions, declared_flags(WorldOptions))  # each field's Meta says its flag


def scenario_ids(sc: Scenario) -> dict[str, list[int]]:
    """The ids the scenario names for its agents (an agent's ``--id``, the chair's robot), by the
    name each registers under (the chair's robot is both its bridge's and its agent's)."""
    out = {agent_name(i, a): [r] for i, a in enumerate(sc.agents) if (r := asked_id(a.argv)) is not None}
    if sc.chair is not None:
        out[SERIAL_BRIDGE] = [sc.chair.robot]
    return out


def world_options(sc: Scenario) -> tuple[WorldOptions, list[str]]:
    """The world's options for a scenario (its ``[world]`` fields, roster and obstacles), and the
    command line's rest (none: ``[world]`` is typed, checked when the scenario was read)."""
    w = sc.world
    shared = {f: getattr(w, f) for f in WorldSettings.__struct_fields__}  # [world] says them as they are
    options = WorldOptions(
        **shared,
        map=str(w.map),
        grid=str(w.grid) if w.grid else "",
        duration_s=w.duration_s,
        expect=sc.robots if w.expect is None else w.expect,
        obstacles=sc.obstacles,
        reserved=scenario_ids(sc) or None,
    )
    return options, []
