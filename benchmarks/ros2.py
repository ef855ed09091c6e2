"""What ``iwz ros2`` costs: its CPU per tick and the latency it adds from the world's state to each
chair's odom on the bus, with 1, 10 and 100 chairs.

    python benchmarks/ros2.py                  # 1, 10 and 100 chairs, 15 s each
    python benchmarks/ros2.py --chairs 10 --seconds 30 --json

Each measurement runs, each its own process on loopback: ``iwz router``, ``iwz world`` (real
time, 100 ms ticks, an open 100 x 100 m lab, the chairs 2 m apart), ``iwz collision``, ``iwz
sensors`` and ``iwz ros2 --robots N`` (each chair with one 64-beam laser and the four default
cones: per tick it publishes N odom, N scans, 4N ranges, one /tf and one /clock, and answers N
actions). The driver, a Zenoh client of its own, stamps each world state and each odom as they
arrive; the added latency of a tick is ``odom arrival - state arrival`` for the same simulation
time (both through the router). ``cpu_ms_per_tick`` is the ros2 process's CPU (user + system,
from /proc) over the measured window, per tick.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import zenoh  # noqa: E402

from benchmarks import exit_on_sigterm, stop_all, workdir  # noqa: E402
from iw_zenoh import keys  # noqa: E402
from iw_zenoh.bus import ZenohBus  # noqa: E402
from iw_zenoh.bus.net import NetConfig, free_port, port_in_use  # noqa: E402
from iw_zenoh.core.lab import Grid, GridPosition, Lab  # noqa: E402
from iw_zenoh.maps import grid_to_xml, lab_to_xml  # noqa: E402
from iw_zenoh.messages import WorldState, decode  # noqa: E402
from iw_zenoh.ros2 import types as t  # noqa: E402

SPEC = {"lasers": [{"id": 0, "fov_deg": 270, "beams": 64, "range_m": 10}]}
TICK_S = 0.1


def _cpu_s(pid: int) -> float:
    """A process's user + system CPU so far, s (/proc/PID/stat)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _files(tmp: Path, n: int) -> tuple[Path, Path]:
    side = 100.0
    lab, grid = tmp / "lab.xml", tmp / "grid.xml"
    lab.write_bytes(lab_to_xml(Lab("bench", side, side)))
    per_row = 40
    pos = tuple(GridPosition(5.0 + 2.0 * (k % per_row), 5.0 + 2.0 * (k // per_row), 0.0) for k in range(n))
    grid.write_bytes(grid_to_xml(Grid(pos)))
    return lab, grid


def measure(n: int, seconds: float, tmp: Path) -> dict[str, float]:
    """One measurement with ``n`` chairs."""
    port = free_port()
    ep = f"tcp/127.0.0.1:{port}"
    sim = f"r2b{n}"
    lab, grid = _files(tmp, n)
    iwz = [sys.executable, "-m", "iw_zenoh.cli"]
    common = ["--sim", sim, "-e", ep]
    logs = [open(tmp / f"{name}-{n}.log", "wb") for name in ("router", "world", "collision", "sensors", "ros2")]  # noqa: SIM115
    procs: list[subprocess.Popen[bytes]] = []
    try:
        procs.append(subprocess.Popen([*iwz, "router", "--sim", sim, "--listen", ep], stdout=logs[0], stderr=logs[0]))
        while not port_in_use(port):
            time.sleep(0.05)  # polling a port: there is no event to wait on
        procs.append(
            subprocess.Popen([*iwz, "world", str(lab), "--grid", str(grid), *common], stdout=logs[1], stderr=logs[1])
        )
        procs.append(subprocess.Popen([*iwz, "collision", *common], stdout=logs[2], stderr=logs[2]))
        procs.append(subprocess.Popen([*iwz, "sensors", *common], stdout=logs[3], stderr=logs[3]))
        ros2 = subprocess.Popen(
            [*iwz, "ros2", "--robots", str(n), "--id", "1", "--spec-json", json.dumps(SPEC), *common],
            stdout=logs[4],
            stderr=logs[4],
        )
        procs.append(ros2)
        return _observe(ep, sim, n, seconds, ros2.pid)
    finally:
        stop_all(procs)
        for f in logs:
            f.close()


def _observe(ep: str, sim: str, n: int, seconds: float, pid: int) -> dict[str, float]:
    bus = ZenohBus(NetConfig(connect=(ep,)))
    state_at: dict[int, int] = {}
    lat_ms: list[float] = []
    odoms = threading.Event()
    lock = threading.Lock()

    def on_state(s: zenoh.Sample) -> None:
        now = time.monotonic_ns()
        st = decode(s.payload.to_bytes(), WorldState)
        with lock:
            state_at[st.sim_time_ns] = now

    def on_odom(s: zenoh.Sample) -> None:
        now = time.monotonic_ns()
        o = t.store().deserialize_cdr(s.payload.to_bytes(), t.ODOMETRY)
        ns = o.header.stamp.sec * 1_000_000_000 + o.header.stamp.nanosec
        with lock:
            if ns in state_at and measuring.is_set():
                lat_ms.append((now - state_at[ns]) / 1e6)
        odoms.set()

    measuring = threading.Event()
    odom_all = keys.ros2_in_every_namespace(0, "odom", t.dds_name(t.ODOMETRY), t.type_hash(t.ODOMETRY))
    subs = [
        bus.session.declare_subscriber(keys.state(sim), on_state),
        bus.session.declare_subscriber(odom_all, on_odom),
    ]
    try:
        if not odoms.wait(120 + n):
            raise SystemExit(f"no odom from iwz ros2 with {n} chairs")
        time.sleep(3.0)  # let every chair register and the first ticks settle
        cpu0, t0 = _cpu_s(pid), time.monotonic()
        measuring.set()
        time.sleep(seconds)
        measuring.clear()
        cpu1, t1 = _cpu_s(pid), time.monotonic()
    finally:
        for s in subs:
            s.undeclare()  # type: ignore[no-untyped-call]
        bus.close()
    ticks = (t1 - t0) / TICK_S
    lat = sorted(lat_ms)
    return {
        "chairs": n,
        "cpu_ms_per_tick": 1000.0 * (cpu1 - cpu0) / ticks,
        "latency_ms_p50": statistics.median(lat) if lat else float("nan"),
        "latency_ms_p99": lat[int(0.99 * (len(lat) - 1))] if lat else float("nan"),
        "odom_per_tick": len(lat) / ticks,
    }


def main(argv: list[str] | None = None) -> int:
    exit_on_sigterm()
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--chairs", type=int, nargs="+", default=[1, 10, 100])
    p.add_argument("--seconds", type=float, default=15.0)
    p.add_argument("--json", action="store_true")
    p.add_argument("--logs", help="keep the processes' logs in DIR")
    args = p.parse_args(argv)
    out = []
    with workdir(args.logs, "ros2") as tmp:
        for n in args.chairs:
            r = measure(n, args.seconds, Path(tmp))
            out.append(r)
            if not args.json:
                print(
                    f"{n:4d} chairs: ros2 CPU {r['cpu_ms_per_tick']:6.2f} ms/tick, state->odom "
                    f"p50 {r['latency_ms_p50']:6.2f} ms p99 {r['latency_ms_p99']:6.2f} ms, "
                    f"{r['odom_per_tick']:.1f} odom/tick",
                    flush=True,
                )
    if args.json:
        print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
