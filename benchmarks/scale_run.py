"""The scale benchmark's processes: one measurement's router, world, collision, sensor shards
and probe agents, with their map, grid and (``--secure``) identities; stopped by pid when done.

Split from ``benchmarks/scale.py`` (which re-exports :class:`Run`: ``profile_tick.py`` and
``memory.py`` import it from there); the measurements and the command line stay there.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from pathlib import Path

from benchmarks import stop_all
from benchmarks.floor import crowded_floor
from iw_zenoh.bus.net import NetConfig, free_port, port_in_use
from iw_zenoh.core.geometry import wrap_deg
from iw_zenoh.core.lab import Grid, GridPosition
from iw_zenoh.maps import grid_to_xml, lab_to_xml
from iw_zenoh.process.runtime import SUPERVISOR_ENV
from iw_zenoh.secure.certs import init_ca, issue
from iw_zenoh.secure.cli import add_identity

__all__ = ["DEBUG", "PUSHING", "SECURITY", "Run"]

# set from scale.py's command line (--debug, --pushing, --security)
DEBUG = bool(os.environ.get("IWZ_BENCH_DEBUG"))  # world and sensors log each tick's timings (-vv)
PUSHING = False  # chairs push into whatever they meet instead of creeping back and forth
SECURITY = "audit"  # --secure as: "tls" (no access control), "acl" (no refusal log), "audit" (all)


class Run:
    """Processes of one measurement; stopped (by pid) when done."""

    def __init__(self, tmp: Path, n: int, *, secure: bool = False) -> None:
        self.tmp = tmp
        self.port = free_port()
        self.ids = tmp / "ids" if secure else None
        self.level = SECURITY if secure else None
        self.endpoint = f"{'tls' if secure else 'tcp'}/127.0.0.1:{self.port}"
        self.procs: list[subprocess.Popen[bytes]] = []
        self.names: list[str] = []
        scene, _, pose = crowded_floor(n)
        self.lab = tmp / "floor.xml"
        self.grid = tmp / "grid.xml"
        self.lab.write_bytes(lab_to_xml(scene.lab))
        starts = tuple(GridPosition(float(x), float(y), float(wrap_deg(math.degrees(h)))) for x, y, h in pose)
        self.grid.write_bytes(grid_to_xml(Grid(starts)))

    def identities(self, shards: int, per_host: list[int]) -> None:
        """Secured: the authority, every process's identity and the policy (each agent its chairs)."""
        assert self.ids is not None
        init_ca(self.ids)
        issue(self.ids, "router", server=True)
        policy = self.ids / "policy.toml"
        policy.write_text('sim = "bench"\n')
        named = [("world", "world"), ("collision", "collision"), ("observer", "recorder")]
        named += [(f"sensors{k}", "sensors") for k in range(1, shards + 1)]
        first = 1
        for i, c in enumerate(per_host):
            issue(self.ids, f"probe{i}")
            add_identity(policy, f"probe{i}", ["agent"], robots=list(range(first, first + c)))
            first += c
        for name, role in named:
            issue(self.ids, name)
            add_identity(policy, name, [role])

    def net(self, name: str) -> NetConfig:
        """How the measuring session joins (secured: as ``name``)."""
        return NetConfig(connect=(self.endpoint,), identity=str(self.ids / name) if self.ids else None)

    def command(self, name: str) -> list[str]:
        """How the process ``name`` is started, before the role's arguments (``profile_tick.py``
        starts some under a profiler)."""
        del name
        return [sys.executable, "-m", "iw_zenoh.cli"]

    def spawn(self, name: str, *args: str, client: bool = True) -> subprocess.Popen[bytes]:
        net = ["-e", self.endpoint] if client else ["--listen", self.endpoint]
        if self.ids is not None:
            who = name if name.startswith(("probe", "sensors", "world", "collision")) else "router"
            net += ["--identity", str(self.ids / who), "--name", who] if client else ["--identity", str(self.ids / who)]
            if name == "router" and self.level != "tls":
                net += ["--policy", str(self.ids / "policy.toml")]
                net += ["--no-audit"] if self.level == "acl" else []
        log = (self.tmp / f"{name}.log").open("wb")
        p = subprocess.Popen(
            [*self.command(name), *args, "--sim", "bench", *net],
            stdout=log,
            stderr=subprocess.STDOUT,
            # a benchmark killed leaves no role running (and holding the cores the next one measures)
            env=dict(os.environ, PYTHONUNBUFFERED="1", **{SUPERVISOR_ENV: str(os.getpid())}),
        )
        self.procs.append(p)
        self.names.append(name)
        return p

    def cpu_s(self) -> dict[str, float]:
        """CPU seconds each role has used so far (user + system, from /proc; agents summed)."""
        tick = os.sysconf("SC_CLK_TCK")
        out: dict[str, float] = {}
        for name, p in zip(self.names, self.procs, strict=True):
            try:
                fields = Path(f"/proc/{p.pid}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue  # gone (the world ends the run)
            role = "agents" if name.startswith("probe") else name.rstrip("0123456789") or name
            out[role] = out.get(role, 0.0) + (int(fields[11]) + int(fields[12])) / tick
        return out

    def start_router(self, timeout_s: float = 20.0) -> None:
        """Starts the router and waits until its port takes connections."""
        self.spawn("router", "router", client=False)
        deadline = time.monotonic() + timeout_s
        while not port_in_use(self.port):
            if time.monotonic() > deadline:
                raise RuntimeError(f"the router did not start within {timeout_s:g} s; see {self.tmp / 'router.log'}")
            time.sleep(0.05)  # polling the port: the router tells nothing when it listens

    def start(
        self,
        *,
        lockstep: bool,
        chairs: int,
        hosts: int,
        duration_s: float,
        shards: int = 1,
        probe_out: str | None = None,
    ) -> subprocess.Popen[bytes]:
        per = [chairs // hosts + (1 if i < chairs % hosts else 0) for i in range(hosts)]
        if self.ids is not None:
            self.identities(shards, per)
        self.start_router()
        world_args = [
            "world",
            str(self.lab),
            *(["-vv"] if DEBUG else []),
            "--grid",
            str(self.grid),
            "--expect",
            str(chairs),
            "--duration",
            f"{duration_s:g}",
        ]
        if lockstep:
            world_args += ["--lockstep", "--lockstep-timeout-ms", "10000"]
        if self.ids is not None and self.level != "tls":
            world_args += ["--policy", str(self.ids / "policy.toml")]
        world = self.spawn("world", *world_args)
        self.spawn("collision", "collision", *(["-vv"] if DEBUG else []))
        for k in range(1, shards + 1):
            self.spawn(
                f"sensors{k}",
                "sensors",
                "--shard",
                f"{k}/{shards}",
                *(["-vv"] if DEBUG else []),
            )
        for i, c in enumerate(per):
            extra = ["--latency-out", f"{probe_out}.{i}"] if probe_out else []
            self.spawn(
                f"probe{i}",
                "agent",
                "probe",
                "--count",
                str(c),
                "--creep",
                "0.02",
                "--avoid",
                "0" if PUSHING else "0.3",
                "--name",
                f"probe{i}",
                *extra,
            )
        return world

    def stop(self) -> None:
        stop_all(self.procs, timeout_s=30)
