"""A scenario file's tables, declared once: each field's name, type, range and default, as
msgspec Structs that the TOML is decoded into (:mod:`iw_zenoh.scenario.file` reads, checks and
refuses; ``docs/scenarios.md`` has every field). The ranges are checked when a file is read,
before anything starts."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import msgspec
import numpy as np

from iw_zenoh.messages import Obstacle
from iw_zenoh.sim.config import WorldSettings

__all__ = [
    "DEPTH_MAX",
    "DURATION_S_MAX",
    "EXTENT_M",
    "NAME",
    "SEED_MAX",
    "AgentEntry",
    "BridgeSection",
    "ChairSection",
    "Criteria",
    "DoorCriterion",
    "ObstacleEntry",
    "Reach",
    "RolesSection",
    "Ros2Section",
    "RoomBox",
    "Scenario",
    "ScenarioFile",
    "SecuritySection",
    "Start",
    "WorldSection",
]

ObstacleEntry = Obstacle  # a scenario's obstacle is the very message the world is sent
Arg = str | int | float  # an argument as TOML writes it; handed on as its text

# the ranges of docs/scenarios.md, checked when the file is read (before anything starts)
SEED_MAX = 2**64 - 1  # numpy's seeds are 64-bit here
ID_MAX = 2**63 - 1  # a robot id: 63 bits
DURATION_S_MAX = 7 * 86_400.0  # a week of simulated time
ROBOTS_MAX = 1000  # robots one agent process registers
EXTENT_M = 10_000.0  # any coordinate or length, m (obstacles, goals, doorways)
DEPTH_MAX = 16  # tables and arrays nested deeper are refused (no scenario needs more than 4)
NAME = r"^([A-Za-z0-9][A-Za-z0-9._-]{0,63})?$"  # a name safe for a file name: a log, a recording
Name = Annotated[str, msgspec.Meta(pattern=NAME)]
Coord = Annotated[float, msgspec.Meta(ge=-EXTENT_M, le=EXTENT_M)]


class WorldSection(WorldSettings, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[world]``: the map and how the world runs: :class:`~iw_zenoh.sim.config.WorldSettings`
    (each of ``iwz world``'s options a typed field, declared there once) and what a scenario adds."""

    map: Path
    grid: Path | None = None
    duration_s: Annotated[float, msgspec.Meta(gt=0, le=DURATION_S_MAX)] = 60.0
    expect: Annotated[int, msgspec.Meta(ge=0, le=ID_MAX)] | None = None  # None: the robots the agents register
    args: tuple[Arg, ...] = ()  # refused (the argv of before): the fields above say it typed (refused.args_table)


class RolesSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[roles]``: which roles run beside the world, and how many."""

    sensors_shards: Annotated[int, msgspec.Meta(ge=1)] = 1  # at most the cores (checked on reading)
    radio: bool = True


class AgentEntry(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[[agents]]``: one agent process: a program of ``iw_zenoh.agents``, or the user's own file
    (``./my_agent.py[:Name]``, relative to the scenario), and its arguments."""

    program: str
    args: tuple[Arg, ...] = ()
    robots: Annotated[int, msgspec.Meta(ge=0, le=ROBOTS_MAX)] = 1
    name: Name = ""
    # its robots' spec as data (docs/spec.md): a table of the registration's fields, or a spec
    # file's path; read and checked when the scenario is, then handed to the agent as a table
    spec: dict[str, Any] | str | None = None
    seed: Annotated[int, msgspec.Meta(ge=0)] | None = None  # its agents' args.seed; None: drawn from [world] seed

    @property
    def argv(self) -> list[str]:
        """``args`` as a command line takes them."""
        return [str(a) for a in self.args]


class Reach(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[[criteria.reach]]``: robot ``robot`` must come within ``within_m`` metres of (``x_m``, ``y_m``)."""

    robot: Annotated[int, msgspec.Meta(ge=0, le=ID_MAX)]
    x_m: Coord
    y_m: Coord
    within_m: Annotated[float, msgspec.Meta(gt=0, le=EXTENT_M)] = 0.5


class DoorCriterion(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[[criteria.doors]]``: what door ``robot`` must do (``iw_zenoh/sim/doorwatch.py`` judges it).

    Its pose when first seen is its closed pose. It opened once it moved ``OPEN_M`` or turned
    ``OPEN_DEG`` from there; it is closed again when back within ``SHUT_M`` and ``SHUT_DEG`` (its
    heading taken modulo ``symmetry_deg``: a four-wing revolving door looks shut every 90 degrees).
    """

    robot: Annotated[int, msgspec.Meta(ge=0, le=ID_MAX)]
    opened: bool = True
    closed_again: bool = True
    x_m: Coord | None = None
    y_m: Coord | None = None
    one_chair_within_m: Annotated[float, msgspec.Meta(gt=0, le=EXTENT_M)] | None = None
    symmetry_deg: Annotated[float, msgspec.Meta(gt=0, le=360)] = 360.0


class Criteria(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[criteria]``: what makes a run a success."""

    max_collisions: Annotated[int, msgspec.Meta(ge=0, le=ID_MAX)] | None = None
    reach: tuple[Reach, ...] = ()
    doors: tuple[DoorCriterion, ...] = ()
    stop_when_reached: bool = True


class BridgeSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[bridge]``: a legacy XML/UDP bridge (Ciber-Rato) beside the world."""

    port: Annotated[int, msgspec.Meta(ge=1, le=65535)] = 6000
    params: Path | None = None
    scoring: Literal[0, 1, 2, 3] = 0


class Start(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[chair] start = { x_m = 1.5, y_m = 3.0, dir_deg = 0.0 }``: where a chair starts."""

    x_m: Coord = 1.0
    y_m: Coord = 1.0
    dir_deg: Annotated[float, msgspec.Meta(ge=-180.0, le=180.0)] = 0.0

    @property
    def arg(self) -> str:
        """As a command line takes it (``--start x,y,dir_deg``)."""
        return f"{self.x_m!r},{self.y_m!r},{self.dir_deg!r}"


class RoomBox(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[chair] room = [{ x0_m = 8.2, y0_m = 3.4, x1_m = 8.8, y1_m = 5.0 }]``: a box of an emulated chair's room."""

    x0_m: Coord
    y0_m: Coord
    x1_m: Coord
    y1_m: Coord

    @property
    def arg(self) -> str:
        """As a command line takes it (``--room x0,y0,x1,y1;...``, one part)."""
        return f"{self.x0_m!r},{self.y0_m!r},{self.x1_m!r},{self.y1_m!r}"


class ChairSection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[chair]``: a real chair on a serial link (``docs/serial.md``): ``iwz bridge serial``, and
    without a ``port`` the chair emulator on a pseudo-terminal. The world must run in real time."""

    hardware: Literal["serial"] = "serial"
    port: str = ""  # the chair's device or pyserial URL; "": `iwz chair emulate --pty` stands in
    robot: Annotated[int, msgspec.Meta(ge=1, le=ID_MAX)] = 1  # the robot id the bridge registers
    name: Name = "chair"
    start: Start | str = msgspec.field(default_factory=Start)  # a string ("1,1,0", as before) is refused: a table
    room: tuple[RoomBox, ...] | str = ()  # emulator: real obstacles not in the map; a string (as before) is refused
    seed: Annotated[int, msgspec.Meta(ge=0)] = 0  # emulator: noise seed, 64 bits at most (_numbers)
    baud: Annotated[int, msgspec.Meta(gt=0, le=10_000_000)] = 115200
    spec: Path | None = None  # a spec file (docs/spec.md) the bridge and the emulator both read


class Ros2Section(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[ros2]``: how the chairs of ``[[agents]]`` entries with ``program = "ros2"`` (each run by
    ``iwz ros2``) meet a ROS 2 stack (docs/ros2.md)."""

    domain_id: Annotated[int, msgspec.Meta(ge=0, le=232)] = 0  # ROS_DOMAIN_ID
    namespace: str = "/robot{id}"  # each chair's namespace; {id} is its robot id
    stamped: bool = False  # cmd_vel is geometry_msgs/TwistStamped (else Twist)


class SecuritySection(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``[security]``: run every role with an identity of its own (docs/security.md), and where.

    ``hosts`` maps a host's name to the processes it runs (``world``, ``collision``,
    ``sensors-1``, ``recorder``, an agent's name...); ``iwz run --host NAME`` starts only those.
    A process no host names runs on the router's host (the one started without ``--host``).
    ``audit = false`` starts the router with ``--no-audit``: the policy is still enforced, but
    refusals go unreported (the router then reads no per-message log; docs/security.md has the cost).
    """

    enabled: bool = True
    hosts: dict[str, list[str]] = {}
    audit: bool = True


class ScenarioFile(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A scenario file's tables, as written (paths still relative to the file)."""

    world: WorldSection
    name: Name = ""
    roles: RolesSection = msgspec.field(default_factory=RolesSection)
    agents: tuple[AgentEntry, ...] = ()
    obstacles: tuple[Obstacle, ...] = ()
    criteria: Criteria = msgspec.field(default_factory=Criteria)
    bridge: BridgeSection | None = None
    chair: ChairSection | None = None
    security: SecuritySection | None = None
    ros2: Ros2Section = msgspec.field(default_factory=Ros2Section)


class Scenario(ScenarioFile, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A whole run: the file's tables with paths resolved, and the folder it came from.

    Attributes:
        base: The scenario's folder: agents run there, so their file arguments are relative to it.
    """

    base: Path = Path(".")

    @property
    def robots(self) -> int:
        """Robots the agents register in all."""
        return sum(a.robots for a in self.agents)

    def agent_seed(self, index: int) -> int:
        """The seed ``agents[index]`` is handed (``--seed``, its agents' ``args.seed``): the entry's
        own ``seed``, else the ``index``-th child of ``[world] seed`` (``np.random.SeedSequence``), so
        every entry's differs and the world's seed changes them all, the same every run.

        Args:
            index: The entry's place in ``agents``.

        Returns:
            A seed in [0, 2**32).
        """
        own = self.agents[index].seed
        if own is not None:
            return own
        return int(np.random.SeedSequence(self.world.seed, spawn_key=(index,)).generate_state(1)[0])
