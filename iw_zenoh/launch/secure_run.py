"""``iwz run --secure``: an identity for every process of a scenario, the policy made from it,
and which host runs which process (docs/security.md).

Each process's identity is its liveliness name (``world``, ``sensors-1-2``, an agent's name...); the launcher
itself is ``launcher``, an operator (it stops the world when the goals are reached). An agent's
robots are its ``--id`` (or, without one, the lowest ids no other agent names), so the router lets
it publish for those alone and the world registers no other for it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from iw_zenoh.agent.programs import program_label
from iw_zenoh.errors import ConfigError
from iw_zenoh.launch.child import Child
from iw_zenoh.nodes.role_options import SensorsOptions
from iw_zenoh.scenario.tables import AgentEntry, Scenario
from iw_zenoh.secure.certs import CA_CERT, init_ca, issue
from iw_zenoh.secure.cli import HEADER, POLICY_FILE, add_identity
from iw_zenoh.secure.policy import load_policy

__all__ = [
    "LAUNCHER",
    "LEGACY_BRIDGE",
    "ROUTER",
    "SERIAL_BRIDGE",
    "agent_name",
    "agent_robots",
    "bridge_robots",
    "identities",
    "on_host",
]

LAUNCHER = "launcher"
ROUTER = "router"
LEGACY_BRIDGE = "ciberrato"  # `iwz bridge ciberrato`'s name: it registers legacy robots under it
SERIAL_BRIDGE = "bridge-serial"  # `iwz bridge serial`'s name in a run (its own default is serial-PID)
_ROLES = {
    "record": ("recorder",),
    LEGACY_BRIDGE: ("bridge", "operator"),  # a legacy viewer starts and pauses
    SERIAL_BRIDGE: ("serial",),  # it publishes no actions
}


def refuse_ros2(sc: Scenario) -> None:
    """A secured run cannot have ``iwz ros2`` (an ``[[agents]]`` program ``ros2``): the policy
    grants our roles only, so its odom, /tf, /clock and rmw_zenoh tokens, and every cmd_vel to it,
    would be dropped by the router without a word (docs/ros2.md). Refused before anything starts.

    Raises:
        ConfigError: The scenario has a ros2 agent.
    """
    for i, a in enumerate(sc.agents):
        if a.program == "ros2":
            raise ConfigError(
                "--secure",
                f"scenario {sc.name!r}: agent {agent_name(i, a)} is `iwz ros2`, which a secured run cannot serve: "
                "the router's policy grants no ROS 2 keys (odom, /tf, /clock, cmd_vel, rmw_zenoh's tokens), so "
                "the chair would never be driven; run it without --secure (and without [security] enabled), "
                "or drop the ros2 agent (docs/ros2.md)",
            )


def bridge_robots(sc: Scenario) -> dict[str, list[int] | None]:
    """The scenario's bridges (their names, their identities) and the robots the world registers
    for each: any for the legacy one (its UDP clients choose their ids), the chair's for the
    serial one (neither publishes on an agent's ``robot/ID/actions``)."""
    out: dict[str, list[int] | None] = {LEGACY_BRIDGE: None} if sc.bridge is not None else {}
    if sc.chair is not None:
        out[SERIAL_BRIDGE] = [sc.chair.robot]
    return out


def agent_name(index: int, entry: AgentEntry) -> str:
    """The name of the scenario's ``index``-th agent process (its liveliness, log and identity)."""
    return entry.name or f"agent-{index + 1}-{program_label(entry.program)}"


def asked_id(argv: Sequence[str]) -> int | None:
    for flag, value in zip(argv, argv[1:], strict=False):
        if flag == "--id" and value.isdigit() and int(value) > 0:
            return int(value)
    return None


def agent_robots(sc: Scenario) -> dict[str, tuple[int, ...]]:
    """Each agent process's robots: its ``--id``, or the lowest ids no other agent asks for."""
    asked = {agent_name(i, a): asked_id(a.argv) for i, a in enumerate(sc.agents)}
    taken = {r for r in asked.values() if r is not None}
    if sc.chair is not None:
        taken.add(sc.chair.robot)
    out: dict[str, tuple[int, ...]] = {}
    free = (r for r in range(1, 100_000) if r not in taken)
    for i, a in enumerate(sc.agents):
        name = agent_name(i, a)
        mine = asked[name]
        out[name] = (mine,) if mine is not None else tuple(next(free) for _ in range(a.robots))
    return out


def identities(
    ids: Path, sim: str, children: Sequence[Child], robots: dict[str, tuple[int, ...]], hosts: Sequence[str]
) -> Path:
    """Makes (or reuses) the run's authority and an identity per process in ``ids``, and the policy.

    Identities already there are kept (the same folder copied to every host of a run).

    Args:
        ids: The folder.
        sim: The simulation the policy guards.
        children: The processes (the chair emulator, on no bus, gets none).
        robots: Each agent's robots (:func:`agent_robots`), and the serial bridge's (its chair's).
        hosts: Names or addresses the router is reached at, beside loopback.

    Returns:
        The policy file.

    Raises:
        ConfigError: A policy of another simulation there, or a refused identity.
    """
    if not (ids / CA_CERT).exists():
        init_ca(ids)
    policy = ids / POLICY_FILE
    if not policy.exists():
        policy.write_text(HEADER.format(sim=sim), encoding="utf-8")
    elif load_policy(policy).sim != sim:
        raise ConfigError(str(policy), f"guards another simulation than {sim!r}: use another --ids folder")
    wanted = [(ROUTER, ()), (LAUNCHER, ("operator",))]
    wanted += [
        (c.token or c.name, _ROLES.get(c.token, _ROLES.get(c.role, (c.role,))))
        for c in children
        if c.role not in ("router", "chair")
    ]
    shards = {c.token or c.name: c.options.shard for c in children if isinstance(c.options, SensorsOptions)}
    for name, roles in wanted:
        if not (ids / f"{name}.crt").exists():
            issue(ids, name, server=name == ROUTER, hosts=tuple(hosts) if name == ROUTER else ())
        shard = "{}/{}".format(*shards[name]) if name in shards else ""
        if roles:
            mine = robots.get(name, ()) if "agent" in roles or "serial" in roles else ()
            add_identity(policy, name, roles, robots=mine, shard=shard)
    return policy


def on_host(children: Sequence[Child], hosts: dict[str, list[str]], host: str) -> list[Child]:
    """The processes ``host`` runs: those ``hosts[host]`` names; without a host, every process
    no host names (the router's host).

    Raises:
        ConfigError: An unknown host, or a host naming a process the scenario does not have.
    """
    names = {c.name for c in children}
    for h, mine in hosts.items():
        unknown = sorted(set(mine) - names)
        if unknown:
            raise ConfigError(f"security.hosts.{h}", f"no such process {unknown}; the processes are {sorted(names)}")
    if host and host not in hosts:
        raise ConfigError("--host", f"the scenario names no host {host!r}; its hosts are {sorted(hosts)}")
    if host:
        return [c for c in children if c.name in hosts[host]]
    elsewhere = {n for mine in hosts.values() for n in mine}
    return [c for c in children if c.name not in elsewhere]
