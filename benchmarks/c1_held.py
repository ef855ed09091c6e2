"""Held ticks in real-time C1 runs: the legacy bridge at its 50 ms cycle, noise-free, against the
legacy simulator's own trajectory (issue #22: "noise-free C1 runs with a held tick").

    python benchmarks/c1_held.py                        # 8 runs (about 40 s each)
    python benchmarks/c1_held.py --quick                # 2 runs
    python benchmarks/c1_held.py --runs 20 --json       # one JSON object
    python benchmarks/c1_held.py --quick --logs /tmp/c1 # keep each run's logs (the world's at -vv)

Each run starts a router, the world (C1 lab and grid, ciberrato profile, 50 ms period, REAL TIME,
paused), collision, sensors and the legacy bridge with the parity parameters (every noise 0), then
drives the parity trace's scripted robot (``benchmarks/parity.py``, what
``tests/integration/test_legacy_parity.py`` runs in lock-step) for 400 cycles, Start sent by a
viewer. A client of the bus records every world state (its ``held`` flag and ``held_reason``) and
every ``holding`` / ``resumed`` event, and when each proposal and verdict reached it; the world's
and collision's own per-tick logs (``-vv``: how late the tick started, how long the world waited
for the verdict; when the proposal reached collision, how long collision took) say where a held
tick's time went.

Printed per run: the world's wait for the verdict against its budget; each held tick with those
timings and their reading (:data:`CAUSES`); whether the trajectory matched the legacy simulator's
(else the first row that differs, cycles never heard, answers sent after the next tick began).
Then: runs with a held tick out of N, runs matching, held ticks by cause.

Target: 0 of N runs with a held tick (the legacy simulator never holds a robot).
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import os
import re
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import exit_on_sigterm, stop_all, workdir  # noqa: E402
from benchmarks.parity import (  # noqa: E402
    PARAMS,
    ROBOT,
    LegacyClient,
    displaced,
    drive,
    first_difference,
    real_rows,
    udp_port,
)
from iw_zenoh import keys  # noqa: E402
from iw_zenoh.bus import Inbox, ZenohBus  # noqa: E402
from iw_zenoh.bus.net import NetConfig, free_port, port_in_use  # noqa: E402
from iw_zenoh.messages import Event, EventKind, Proposed, WorldState, decode, stamp_of  # noqa: E402
from iw_zenoh.sim.config import WorldConfig  # noqa: E402

PERIOD_MS = 50.0
MAPS = Path(__file__).resolve().parents[1] / "maps" / "ciberrato"
VERDICT_WAIT_MS = WorldConfig(period_ms=PERIOD_MS).verdict_wait_ns / 1e6  # the real-time budget
TICK_LOG = re.compile(r"tick (\d+): started ([\d.]+) ms late, propose\+verdict ([\d.]+) ms")
VERDICT_LOG = re.compile(r"tick (\d+): proposal arrived ([\d.]+|nan) ms after the tick began, verdict sent ([\d.]+) ms")
ALIVE = (("collision", "collision"), ("sensors", "sensors-1-1"), ("bridge", "ciberrato"))


def _setter(up: threading.Event) -> Callable[[str, bool], None]:
    """A liveliness callback that sets ``up`` when the token appears."""

    def on_change(_key: str, alive: bool) -> None:
        if alive:
            up.set()

    return on_change


class Run:
    """One run's processes, each logging to ``NAME.log`` in ``tmp``; stopped by :meth:`stop`."""

    def __init__(self, tmp: Path, sim: str) -> None:
        self.tmp, self.sim = tmp, sim
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.procs: list[subprocess.Popen[bytes]] = []

    def spawn(self, role: str, *args: str) -> None:
        """Starts ``iwz ROLE ARGS`` on this run's router."""
        with (self.tmp / f"{role}.log").open("wb") as log:
            argv = [sys.executable, "-m", "iw_zenoh.cli", role, *args, "--sim", self.sim]
            self.procs.append(
                subprocess.Popen(
                    argv if role == "router" else [*argv, "-e", self.endpoint],
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    stdin=subprocess.DEVNULL,
                    env=dict(os.environ, PYTHONUNBUFFERED="1"),
                )
            )

    def start(self) -> int:
        """Router, world, collision, sensors and bridge, each alive; the bridge's UDP port."""
        self.spawn("router", "--listen", self.endpoint)
        port_no = int(self.endpoint.rsplit(":", 1)[1])
        deadline = time.monotonic() + 20
        while not port_in_use(port_no):
            if self.procs[0].poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"the router did not listen on {self.endpoint}: see {self.tmp / 'router.log'}")
            time.sleep(0.02)  # polling a port: there is no event to wait on
        lab, grid = MAPS / "C1-lab.xml", MAPS / "C1-grid.xml"
        world = ("--grid", str(grid), "--profile", "ciberrato", "--period-ms", f"{PERIOD_MS:g}", "--paused", "-vv")
        self.spawn("world", str(lab), *world)
        self.spawn("collision", "-vv")
        self.spawn("sensors")
        udp = udp_port()
        self.spawn("bridge", "ciberrato", "--port", str(udp), "--param", str(PARAMS))
        return udp

    def wait_alive(self, bus: ZenohBus, timeout_s: float = 60.0) -> None:
        """Waits for collision, sensors and bridge to declare themselves alive."""
        for role, name in ALIVE:
            up = threading.Event()
            bus.watch_alive(keys.alive(self.sim, role, name), _setter(up))
            if not up.wait(timeout_s):
                raise RuntimeError(f"{role} {name} not alive within {timeout_s:g} s: see {self.tmp / (role + '.log')}")

    def stop(self) -> None:
        """Stops every process, by pid."""
        stop_all(self.procs)


def _observe(bus: ZenohBus, sim: str) -> dict[str, Inbox]:
    """Every world state, event, proposal and verdict of the run, kept (with when it came) from now on."""
    boxes = {"states": Inbox(), "events": Inbox(), "proposed": Inbox(), "verdicts": Inbox()}
    bus.subscribe(keys.state(sim), boxes["states"])
    bus.subscribe(keys.all_events(sim), boxes["events"])
    bus.subscribe(keys.proposed(sim), boxes["proposed"])
    bus.subscribe(keys.verdict(sim), boxes["verdicts"])
    return boxes


def _arrivals(box: Inbox) -> dict[int, int]:
    """When the first message of each tick reached the observer (ns)."""
    out: dict[int, int] = {}
    for _, data, at in box.drain():
        out.setdefault(stamp_of(data)[0], at)
    return out


def _proposals(box: Inbox) -> tuple[dict[int, int], dict[int, float], dict[int, int]]:
    """When each tick's proposal reached the observer (ns), how long after the tick began (ms),
    and when the world began the tick (ns, its wall clock)."""
    at: dict[int, int] = {}
    after: dict[int, float] = {}
    began: dict[int, int] = {}
    for _, data, t in box.drain():
        msg = decode(data, Proposed)
        if msg.tick not in at:
            at[msg.tick] = t
            after[msg.tick] = (t - msg.tick_wall_ns) / 1e6 if msg.tick_wall_ns else float("nan")
            if msg.tick_wall_ns:
                began[msg.tick] = msg.tick_wall_ns
    return at, after, began


def _logged(path: Path, pattern: re.Pattern[str]) -> dict[int, tuple[float, float]]:
    """A role's per-tick ``-vv`` log as ``{tick: (first figure, second figure)}`` (ms)."""
    text = path.read_text(errors="replace") if path.exists() else ""
    return {int(m[1]): (float(m[2]), float(m[3])) for m in pattern.finditer(text)}


def _drive(port: int, last_t: int, answered: dict[int, int]) -> tuple[list[dict[str, Any]], str]:
    """The scripted robot and a viewer on the bridge; the rows received and what stopped them early
    (``answered``: when each Measures was answered)."""
    robot, viewer = LegacyClient(port), LegacyClient(port)
    try:
        if b'Status="Ok"' not in robot.register(ROBOT) or b'Status="Ok"' not in viewer.register(b"<View/>\n\x00"):
            return [], "the bridge refused the robot or the viewer"
        return drive(robot, viewer, last_t, answered), ""
    except (TimeoutError, AssertionError) as e:
        return [], f"{type(e).__name__}: {e or 'no Measures for 2 s'}"
    finally:
        robot.close()
        viewer.close()


def _judge(rows: list[dict[str, Any]], real: list[dict[str, Any]]) -> dict[str, Any]:
    """The trajectory against the legacy simulator's: matched, rows differing (a Time the robot
    never heard differs), the first of them, the cycles never heard."""
    if not rows:
        return {"matched": False, "rows_differing": len(real), "first_difference": None, "missed_cycles": len(real)}
    missed = set(range(1, len(real) + 1)) - {r["t"] for r in rows}
    diff = first_difference(displaced(rows), displaced(real))
    return {
        "matched": diff is None,
        "rows_differing": 0 if diff is None else diff[0],
        "first_difference": None if diff is None else {"ours": diff[1], "legacy": diff[2]},
        "missed_cycles": len(missed),
    }


def measure(k: int, logs: str | None) -> dict[str, Any]:
    """One run (``k``: its number): held ticks, events, verdict waits, parity."""
    real = real_rows()
    with workdir(logs, f"run{k}", "iwz-c1held-") as tmp:
        run = Run(Path(tmp), f"c1held{k}")
        try:
            port = run.start()
            bus = ZenohBus(NetConfig(connect=(run.endpoint,)))
            try:
                run.wait_alive(bus)
                boxes = _observe(bus, run.sim)
                answered: dict[int, int] = {}
                rows, error = _drive(port, len(real), answered)
                seen = Seen(
                    [decode(d[1], WorldState) for d in boxes["states"].drain()],
                    [decode(d[1], Event) for d in boxes["events"].drain()],
                    *_proposals(boxes["proposed"]),
                    _arrivals(boxes["verdicts"]),
                    answered,
                )
            finally:
                bus.close()
        finally:
            run.stop()
        seen.world = _logged(Path(tmp) / "world.log", TICK_LOG)
        seen.collision = _logged(Path(tmp) / "collision.log", VERDICT_LOG)
    return {"run": k, "error": error, **_held(seen), **_judge(rows, real)}


@dataclass
class Seen:
    """What a run showed: the observer's states, events and arrivals, the roles' per-tick logs."""

    states: list[WorldState]
    events: list[Event]
    proposed_at: dict[int, int]  # tick: when its proposal reached the observer (ns)
    proposal_late: dict[int, float]  # tick: how long after the tick began (ms)
    began: dict[int, int]  # tick: when the world began it (ns, wall clock)
    verdict_at: dict[int, int]  # tick: when its verdict reached the observer (ns)
    answered: dict[int, int]  # Measures Time: when the robot sent its answer (ns, wall clock)
    world: dict[int, tuple[float, float]] = field(default_factory=dict)  # tick: started late, waited (ms)
    collision: dict[int, tuple[float, float]] = field(default_factory=dict)  # tick: proposal in, verdict out

    def verdict_delay_ms(self, tick: int) -> float | None:
        """How long after its proposal the tick's verdict reached the observer (None: never)."""
        if tick not in self.proposed_at or tick not in self.verdict_at:
            return None
        return (self.verdict_at[tick] - self.proposed_at[tick]) / 1e6

    def late_answers(self) -> list[int]:
        """Measures Times the robot answered after the next tick began: too late for it, where the
        legacy simulator applies the answer (an answer sent in time may still arrive late: not
        counted)."""
        began = self.began
        return sorted(t for t, at in self.answered.items() if t + 1 in began and at > began[t + 1])


CAUSES = {  # where a held tick's verdict time went, from the world's and collision's -vv logs
    "unanswered": "collision never answered the proposal (it answers the newest waiting: the next one came too)",
    "proposal late": "the proposal reached collision too late (held up in the send, the router or the receive)",
    "collision slow": "collision sent the verdict too late after the proposal came (slow, or not given the CPU)",
    "verdict late": "collision sent the verdict in time; the world got it after its wait (collision's send, router)",
}


def _cause(arrived: float, computed: float, waited: float) -> str:
    """Where a held tick's verdict time went (a key of :data:`CAUSES`), from collision's log."""
    if math.isnan(arrived):
        return "unanswered"
    if arrived + computed <= waited:
        return "verdict late"
    return "proposal late" if arrived >= computed else "collision slow"


def _held_tick(seen: Seen, s: WorldState) -> dict[str, Any]:
    """One held tick: why, how long the world waited, what became of its verdict."""
    nan = float("nan")
    arrived, computed = seen.collision.get(s.tick, (nan, nan))
    waited = seen.world.get(s.tick, (nan, nan))[1]
    return {
        "tick": s.tick,
        "reason": s.held_reason,
        "cause": _cause(arrived, computed, waited),
        "world_waited_ms": waited,
        "world_started_late_ms": seen.world.get(s.tick, (nan, nan))[0],
        "proposal_at_observer_ms": seen.proposal_late.get(s.tick, nan),  # after the tick began
        "proposal_at_collision_ms": arrived,  # after the tick began (collision's -vv log)
        "collision_ms": computed,  # from the proposal's arrival to the verdict sent
        "verdict_after_proposal_ms": seen.verdict_delay_ms(s.tick),  # at the observer; None: never
    }


def _held(seen: Seen) -> dict[str, Any]:
    """Which ticks held every robot and why, the holding / resumed events, the verdict waits."""
    kinds = (EventKind.HOLDING, EventKind.RESUMED)
    waits = sorted(v for _, v in seen.world.values())
    worst = max(seen.world.items(), key=lambda kv: kv[1][1], default=(0, (0.0, 0.0)))
    delays = [d for d in map(seen.verdict_delay_ms, seen.proposed_at) if d is not None]
    return {
        "states": len(seen.states),
        "held_ticks": [_held_tick(seen, s) for s in seen.states if s.held],
        "events": [{"tick": e.tick, "kind": e.kind.value, "reason": e.reason} for e in seen.events if e.kind in kinds],
        "verdict_ms_p50": waits[len(waits) // 2] if waits else 0.0,
        "verdict_ms_max": worst[1][1],
        "verdict_ms_max_tick": worst[0],
        "started_late_ms_max": max((late for late, _ in seen.world.values()), default=0.0),
        "verdicts_over_budget": sum(1 for d in delays if d > VERDICT_WAIT_MS),
        "verdicts_missing": sum(1 for t in seen.proposed_at if t not in seen.verdict_at),
        "late_answers": seen.late_answers(),
    }


def _print_run(r: dict[str, Any]) -> None:
    print(
        f"run {r['run']}: {len(r['held_ticks'])} held ticks; "
        f"the world's wait for the verdict p50 {r['verdict_ms_p50']:.1f} ms, longest {r['verdict_ms_max']:.1f} ms "
        f"(tick {r['verdict_ms_max_tick']}; budget {VERDICT_WAIT_MS:g} ms); "
        f"ticks started up to {r['started_late_ms_max']:.1f} ms late; verdicts later than "
        f"{VERDICT_WAIT_MS:g} ms after their proposal {r['verdicts_over_budget']}, never {r['verdicts_missing']}"
    )
    for h in r["held_ticks"]:
        came = h["verdict_after_proposal_ms"]
        print(
            f"    held tick {h['tick']} ({h['reason'] or 'no reason given'}): the world started it "
            f"{h['world_started_late_ms']:.1f} ms late, waited {h['world_waited_ms']:.1f} ms; its proposal reached "
            f"the observer {h['proposal_at_observer_ms']:.1f} ms, collision {h['proposal_at_collision_ms']:.1f} ms "
            f"after the tick began; collision's verdict went out {h['collision_ms']:.1f} ms later, reaching the "
            + ("observer never" if came is None else f"observer {came:.1f} ms after the proposal")
            + f"\n      so: {CAUSES[h['cause']]}"
        )
    for e in r["events"]:
        print(f"    event {e['kind']} at tick {e['tick']}: {e['reason']}")
    if r["error"]:
        print(f"    the robot stopped: {r['error']}")
    if r["matched"]:
        print("    trajectory: matches the legacy simulator's, all 400 rows")
        return
    first = r["first_difference"] or {}
    late = r["late_answers"]
    print(
        f"    trajectory: differs ({r['rows_differing']} rows, {r['missed_cycles']} cycles never heard; "
        f"{len(late)} answers sent after the next tick began{': Times ' + str(late[:8]) if late else ''})"
    )
    if first:
        print(f"    first: ours {first['ours'] or 'nothing (a Time never heard)'}\n           legacy {first['legacy']}")


def _no_nan(v: Any) -> Any:
    """``v`` with every NaN (a figure no log gave) as None, so the JSON is standard."""
    if isinstance(v, dict | list):
        return {k: _no_nan(x) for k, x in v.items()} if isinstance(v, dict) else [_no_nan(x) for x in v]
    return None if isinstance(v, float) and math.isnan(v) else v


def main(argv: list[str] | None = None) -> int:
    """Runs the measurements and prints them with the target."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=8, help="how many runs (default 8)")
    ap.add_argument("--quick", action="store_true", help="2 runs whatever --runs says (about a minute and a half)")
    ap.add_argument("--json", action="store_true", help="one JSON object")
    ap.add_argument("--logs", metavar="DIR", help="keep each run's process logs in DIR/runK (the world's at -vv)")
    args = ap.parse_args(argv)
    if args.runs < 1:
        ap.error(f"--runs {args.runs}: give at least 1 run, e.g. --runs 8")
    exit_on_sigterm()
    n = 2 if args.quick else args.runs
    res = []
    for k in range(1, n + 1):
        print(f"  run {k} of {n} ...", file=sys.stderr, flush=True)
        res.append(measure(k, args.logs))
    held_runs = sum(1 for r in res if r["held_ticks"])
    matching = sum(1 for r in res if r["matched"])
    causes = collections.Counter(h["cause"] for r in res for h in r["held_ticks"])
    if args.json:
        out = {
            "benchmark": "c1_held",
            "period_ms": PERIOD_MS,
            "verdict_wait_ms": VERDICT_WAIT_MS,
            "runs": n,
            "runs_held": held_runs,
            "runs_matching": matching,
            "target_runs_held": 0,
            "held_ticks_by_cause": dict(causes),
            "results": res,
        }
        print(json.dumps(_no_nan(out)))
        return 0
    for r in res:
        _print_run(r)
    print(f"{held_runs} of {n} runs with a held tick; {matching} of {n} runs match the legacy simulator")
    for cause, count in causes.most_common():
        print(f"  {count} held ticks: {CAUSES[cause]}")
    print(f"target: 0 of {n} runs with a held tick")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
