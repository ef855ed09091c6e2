"""What ``iwz run`` starts: every role of a scenario as a child process, its command line and
typed options (``--options JSON``), its identity when the run is secured, and which of them run
on this host.
"""

from __future__ import annotations

import json
import sys
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import msgspec

from iw_zenoh import keys
from iw_zenoh.launch.child import Child
from iw_zenoh.launch.secure_run import (
    LEGACY_BRIDGE,
    ROUTER,
    SERIAL_BRIDGE,
    agent_name,
    agent_robots,
    bridge_robots,
    identities,
    on_host,
)
from iw_zenoh.nodes.role_options import BridgeOptions, RadioOptions, RecorderOptions, SensorsOptions
from iw_zenoh.nodes.world_options import WorldOptions
from iw_zenoh.process.options import options_argument
from iw_zenoh.record.metrics import Goal, goals_json
from iw_zenoh.scenario.tables import Scenario, Start
from iw_zenoh.secure.cli import POLICY_FILE

__all__ = ["RunPlan"]


@dataclass
class RunPlan:
    """A run's processes, built in the order they start (the router first, the agents last).

    Attributes:
        scenario: The scenario.
        world: The world's options and the rest of its command line (``world_options``).
        sim: Simulation name (a valid key chunk).
        listen: Where the router listens.
        endpoint: Where every other process connects.
        log_dir: Where each role's log goes (and the emulated chair's pty link).
        ids: A secured run's identities directory; None: not secured.
        record: The recording to write; None: no recorder.
        children: The processes planned so far.
    """

    scenario: Scenario
    world: tuple[WorldOptions, list[str]]
    sim: str
    listen: str
    endpoint: str
    log_dir: Path
    ids: Path | None = None
    record: Path | None = None
    children: list[Child] = field(default_factory=list)

    @staticmethod
    def command(*args: str) -> list[str]:
        """The command line of ``iwz ARGS`` run by this interpreter."""
        return [sys.executable, "-m", "iw_zenoh.cli", *args]

    def child(
        self,
        role: str,
        name: str,
        *args: str,
        options: msgspec.Struct | None = None,
        client: bool = True,
        token: str = "",
    ) -> Child:
        """A child of ``role``: its ``args``, then its typed ``options`` (passed whole, ``--options JSON``);
        secured, its identity is its liveliness name (``token``, or ``name``)."""
        common = ["--sim", self.sim, "-e", self.endpoint] if client else ["--sim", self.sim, "--listen", self.listen]
        if self.ids is not None:
            who = ["--identity", str(self.ids / (token or name if client else ROUTER))]
            common += who if client else [*who, "--policy", str(self.ids / POLICY_FILE)]
        spill = self.log_dir / f"{name}.options.json"
        given = ["--options", options_argument(options, spill)] if options is not None else []
        c = Child(role, name, self.command(role, *args, *given, *common), self.log_dir / f"{name}.log", options=options)
        c.token = token
        self.children.append(c)
        return c

    def build(self, *, host: str = "", remote_router: bool = False) -> list[Child]:
        """Plans every process, each role handed its options as a typed Struct; secured, writes
        every identity and the policy.

        Args:
            host: This host's name in the scenario's ``[security] hosts`` ("": every process).
            remote_router: Another host runs the router: it is not started here.

        Returns:
            The processes this host starts, in start order.
        """
        sc = self.scenario
        quiet = self.ids is not None and sc.security is not None and not sc.security.audit
        self.child("router", "router", *(["--no-audit"] if quiet else []), client=False)
        if self.record is not None:
            self._plan_recorder()
        options, rest = self.world
        robots = agent_robots(sc)
        if self.ids is not None:  # each agent registers its own robots only; a bridge any
            owners: dict[str, list[int] | None] = {n: list(r) for n, r in robots.items()}
            owners.update(bridge_robots(sc))
            options = msgspec.structs.replace(options, owners=owners)
        self.child("world", "world", *rest, options=options)
        self.child("collision", "collision")
        shards = sc.roles.sensors_shards
        for k in range(1, shards + 1):
            self.child(
                "sensors", f"sensors-{k}", options=SensorsOptions(shard=(k, shards)), token=f"sensors-{k}-{shards}"
            )
        if sc.roles.radio:
            self.child("radio", "radio", options=RadioOptions())
        if sc.bridge is not None:
            b = sc.bridge
            bridge = BridgeOptions(port=b.port, param=str(b.params) if b.params else "", scoring=b.scoring)
            self.child("bridge", "bridge", "ciberrato", options=bridge, token=LEGACY_BRIDGE)
        if sc.chair is not None:
            self._plan_chair()
        for i, a in enumerate(sc.agents):
            name = agent_name(i, a)
            spec = ["--spec-json", json.dumps(a.spec)] if a.spec is not None else []  # read and checked: a table
            if a.program == "ros2":  # the chairs a ROS 2 stack drives (docs/ros2.md)
                c = self.child("ros2", name, *self._ros2_args(a.robots), *a.argv, *spec, "--name", name)
                c.role = "agent"  # an agent all the same: started last, stopped first, its chairs its own
            else:
                seed = ["--seed", str(sc.agent_seed(i))]  # before its args: a --seed of its own wins
                c = self.child("agent", name, a.program, *seed, *a.argv, *spec, "--name", name)
            c.cwd, c.token = sc.base.resolve(), keys.chunk(name)
        if self.ids is not None:
            chair = {n: tuple(r) for n, r in bridge_robots(sc).items() if r is not None}  # the serial bridge's
            identities(
                self.ids, self.sim, self.children, robots | chair, [self.listen.rsplit(":", 1)[0].split("/")[-1]]
            )
        hosts = sc.security.hosts if sc.security is not None else {}
        return [c for c in on_host(self.children, hosts, host) if not (remote_router and c.role == "router")]

    def _ros2_args(self, robots: int) -> list[str]:
        """``iwz ros2``'s flags from the scenario's ``[ros2]`` table."""
        r = self.scenario.ros2
        out = ["--robots", str(max(robots, 1)), "--domain", str(r.domain_id), "--namespace", r.namespace]
        return [*out, "--stamped"] if r.stamped else out

    def _plan_recorder(self) -> None:
        """The recorder, with the run's metadata; restarted with these same options, it continues
        this run's recording in its next part."""
        sc = self.scenario
        meta = {"scenario": sc.name, "seed": str(sc.world.seed), "map": str(sc.world.map)}
        if sc.criteria.reach:  # iwz report's time to goal: a JSON array (record/metrics.py recorded_goals reads it)
            meta["goals"] = goals_json({r.robot: Goal(r.x_m, r.y_m, r.within_m) for r in sc.criteria.reach})
        rec = RecorderOptions(output=str(self.record), meta=meta, quiet=True, continue_run=uuid.uuid4().hex)
        self.child("record", "recorder", options=rec)

    def _plan_chair(self) -> None:
        """A real chair's serial bridge; without a port, the chair emulator on a pty (docs/serial.md)."""
        ch, sc = self.scenario.chair, self.scenario
        assert ch is not None
        start = ch.start.arg if isinstance(ch.start, Start) else ch.start  # a string is refused on reading
        room = ch.room if isinstance(ch.room, str) else ";".join(box.arg for box in ch.room)  # as is start
        port = ch.port
        if not port:
            port = str(self.log_dir / "chair-pty")  # a stable link to the emulator's pty
            emulate = ["emulate", "--pty", "--link", port, "--map", str(sc.world.map), "--start", start]
            emulate += ["--spec", str(ch.spec)] if ch.spec is not None else []
            emulate += [
                "--room",
                room,
                "--seed",
                str(ch.seed),
                "--wheels-log",
                str(self.log_dir / "chair-wheels.log"),
            ]
            self.children.append(Child("chair", "chair", self.command("chair", *emulate), self.log_dir / "chair.log"))
        bridge = ["serial", "--port", port, "--robot", ch.name, "--id", str(ch.robot), "--start", start]
        bridge += ["--baud", str(ch.baud), "--log", str(self.log_dir / "bridge-serial.csv")]
        bridge += ["--spec", str(ch.spec)] if ch.spec is not None else []
        self.child("bridge", SERIAL_BRIDGE, *bridge, "--name", SERIAL_BRIDGE, token=SERIAL_BRIDGE)
