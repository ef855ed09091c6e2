"""``iwz resim FILE [--from T] [--agent ID=PROGRAM ARGS] [-o OUT]``: re-run a lock-step recording.

The world, collision check and sensors run again in this process
(:class:`~iw_zenoh.sim.local.LocalWorld`, the tick in one process), from the recording's world
description, registrations, seed and recorded actions; the re-simulated states are compared
with the recorded ones, tick by tick, exactly. With ``--agent``, one robot's recorded actions
are replaced from time T on by a new agent program fed with the re-computed sensors (seeded as
they were live), to see whether a fix avoids an incident.
"""

from __future__ import annotations

import argparse
import shlex
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from iw_zenoh import keys
from iw_zenoh.agent.programs import add_seed_argument, add_spec_arguments, find_program, make_with_spec
from iw_zenoh.convert import grid_from_msg, lab_from_msg
from iw_zenoh.core.modes import Mode
from iw_zenoh.errors import IwError
from iw_zenoh.messages import (
    ActionBatch,
    Actions,
    Event,
    EventKind,
    RegisterReply,
    WorldInfo,
    WorldState,
    encode,
)
from iw_zenoh.record.progress import Progress
from iw_zenoh.record.reader import RecordingReader, file_error, open_recording, print_notes
from iw_zenoh.record.recording import Recorder
from iw_zenoh.sim.local import LocalWorld

__all__ = ["Resim", "load_run", "main", "resimulate"]

RUN_KINDS = ("info", "spec", "actions", "action_batch", "state", "event")  # what a re-simulation reads


@dataclass
class RecordedRun:
    """What a lock-step recording holds for re-simulation."""

    info: WorldInfo
    specs: list[RegisterReply]
    actions: dict[int, dict[int, Actions]] = field(default_factory=dict)  # sensors tick -> robot -> last actions
    states: dict[int, WorldState] = field(default_factory=dict)
    collisions: list[Event] = field(default_factory=list)


def _wanted(topic: str) -> bool:
    """Of the events, only collisions matter to a re-simulation."""
    return keys.topic_kind(topic) != "event" or topic.endswith("/collision")


def load_run(f: IO[bytes] | RecordingReader, progress: Callable[[float, str], None] | None = None) -> RecordedRun:
    """Reads the world description, registrations, actions and states of a recording.

    ``progress`` is told now and then how far through the recording reading has gone.

    Raises:
        IwError: When it holds no world description or is not lock-step.
    """
    info: WorldInfo | None = None
    specs: dict[int, RegisterReply] = {}
    actions: dict[int, dict[int, Actions]] = {}
    states: dict[int, WorldState] = {}
    collisions: list[Event] = []
    # a malformed message was recorded as received (the reader skips it): it never reached the world
    rec = f if isinstance(f, RecordingReader) else RecordingReader(f)
    for i, r in enumerate(rec.records(RUN_KINDS, topics=_wanted)):
        if progress is not None and i % 1000 == 0:
            progress(rec.progress(), f"{i} messages read")
        match r.message:
            case WorldInfo() as wi if info is None:
                info = wi
            case RegisterReply() as reply if reply.ok and reply.robot_id not in specs:
                specs[reply.robot_id] = reply
            case Actions() as a:
                actions.setdefault(a.tick, {})[a.robot_id] = a
            case ActionBatch() as b if keys.agent_of(r.topic) == b.agent:  # one agent host, many robots
                for a in b.actions:
                    actions.setdefault(a.tick, {})[a.robot_id] = a
            case WorldState() as s:
                states[s.tick] = s
            case Event() as e:
                collisions.append(e)
    if info is None:
        raise IwError("the recording holds no world description (iw/SIM/world/info); record with a current iwz")
    if info.mode != Mode.LOCKSTEP:
        raise IwError("only lock-step recordings can be re-simulated exactly (this one ran in real time)")
    return RecordedRun(info, list(specs.values()), actions, states, collisions)


@dataclass
class Resim:
    """The outcome."""

    ticks: int = 0
    identical_until: int = 0
    diverged_at: int | None = None
    collisions: list[tuple[float, int, str]] = field(default_factory=list)
    recorded_collisions: list[tuple[float, int, str]] = field(default_factory=list)


def _make_agent(spec: str) -> tuple[int, Any]:
    rid_text, sep, command = spec.partition("=")
    words = shlex.split(command)
    if not sep or not rid_text.isdigit() or not words:
        raise IwError(f"--agent takes ID=PROGRAM [ARGS...], e.g. 1=waypoint --waypoints '20,6', got {spec!r}")
    program = find_program(words[0])  # a program that ships, or the user's own file
    p = argparse.ArgumentParser(prog=f"agent {words[0]}")
    program.add_arguments(p)
    add_spec_arguments(p)
    add_seed_argument(p)
    agents = make_with_spec(program, p.parse_args(words[1:]))
    return int(rid_text), agents[0]


def _world(run: RecordedRun) -> LocalWorld:
    """The recorded world at its start: its description and seed, its robots registered."""
    info = run.info
    world = LocalWorld(
        lab_from_msg(info.lab),
        grid_from_msg(info.grid),
        seed=info.seed,
        profile=info.profile,
        period_ms=info.period_ns / 1e6,
        sim=info.sim,
    )
    for r in run.specs:
        assert r.spec is not None
        world.add(r.spec)
    return world


def resimulate(
    run: RecordedRun,
    *,
    swap: tuple[int, Any] | None = None,
    from_ns: int = 0,
    out: Recorder | None = None,
    progress: Callable[[float, str], None] | None = None,
) -> Resim:
    """Re-runs a recorded lock-step run; see the module doc (``progress`` is told each tick done)."""
    world = _world(run)
    period_ns = world.cfg.period_ns
    result = Resim(recorded_collisions=[(e.sim_time_ns / 1e9, e.robot_id, e.reason) for e in run.collisions])
    swap_id, swap_agent = swap if swap else (None, None)
    last = max(run.states) if run.states else 0
    own_actions: dict[int, Actions] = {}
    for n in range(1, last + 1):
        now = n * period_ns
        commands: dict[int, Actions] = {
            a.robot_id: a
            for a in run.actions.get(n - 1, {}).values()
            if not (a.robot_id == swap_id and (n - 1) * period_ns >= from_ns)
        }
        commands.update(own_actions)
        own_actions.clear()
        swapping = swap_agent is not None and n * period_ns >= from_ns
        step = world.step(commands, sense=swapping)
        state = step.state
        result.ticks = n
        if progress is not None:
            progress(n / last, f"tick {n} of {last}")
        for e in step.events:
            if e.kind == EventKind.COLLISION:
                result.collisions.append((e.sim_time_ns / 1e9, e.robot_id, e.reason))
        if out is not None:
            for k, m in step.published:
                out.add(k, encode(m), now)
        rec = run.states.get(n)
        same = rec is not None and (rec.ids, rec.x, rec.y, rec.heading) == (state.ids, state.x, state.y, state.heading)
        if same and result.diverged_at is None:
            result.identical_until = n
        elif result.diverged_at is None:
            result.diverged_at = n
        reading = step.readings.get(swap_id) if swapping and swap_id is not None else None
        if reading is not None and swap_agent is not None:
            c = swap_agent.on_sensors(reading, step.heard.get(reading.robot_id, []))
            c = c.resolved(world.spec(reading.robot_id))  # a velocity: the chair's powers
            own_actions[reading.robot_id] = Actions(
                tick=n, sim_time_ns=now, robot_id=reading.robot_id, left=c.left, right=c.right
            )
    return result


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz resim``."""
    p = argparse.ArgumentParser(
        prog="iwz resim",
        description=(
            "Re-run a lock-step recording from its recorded actions and seed; "
            "optionally swap one robot's agent from time T."
        ),
        epilog="Example: iwz resim run.mcap --from 12.5 --agent \"1=waypoint --waypoints '20,6.3'\" -o fixed.mcap",
    )
    p.add_argument("file", help="a lock-step MCAP recording")
    p.add_argument(
        "--from", dest="from_s", type=float, default=0.0, help="simulation time the swapped agent takes over, s"
    )
    p.add_argument(
        "--agent",
        help="ID=PROGRAM [ARGS...]: the agent to drive robot ID instead of its recorded actions "
        "(a program that ships, or your own file: 1=./my_agent.py:GoTo --goal 10.5,3)",
    )
    p.add_argument("-o", "--output", help="write the re-simulated world (states, events) to this MCAP file")
    args = p.parse_args(argv)
    try:
        with open_recording(args.file) as recording:
            reading = Progress("iwz resim: reading")
            run = load_run(recording, reading.update)
            reading.done()
            print_notes("iwz resim", recording)
        swap = _make_agent(args.agent) if args.agent else None
        said = Progress("iwz resim")
        if args.output:
            with Path(args.output).open("wb") as out_file:
                meta = {"iw.resim": {"source": args.file, "from_s": str(args.from_s), "agent": args.agent or ""}}
                rec = Recorder(out_file, meta)
                res = resimulate(run, swap=swap, from_ns=int(args.from_s * 1e9), out=rec, progress=said.update)
                rec.finish()
        else:
            res = resimulate(run, swap=swap, from_ns=int(args.from_s * 1e9), progress=said.update)
        said.done()
    except (OSError, IwError) as e:
        print(f"iwz resim: {file_error(args.file, e)}")
        return 2
    except ImportError as e:
        print(f"iwz resim: {e}")
        return 2
    if res.diverged_at is None:
        print(f"iwz resim: {res.ticks} ticks re-simulated, every state identical to the recording")
    else:
        print(
            f"iwz resim: {res.ticks} ticks; identical to the recording up to tick {res.identical_until}, "
            f"differs from tick {res.diverged_at}"
        )
    print(f"  collisions recorded: {len(res.recorded_collisions)}; re-simulated: {len(res.collisions)}")
    for t, rid, why in res.collisions[:10]:
        print(f"    t={t:.1f} s robot {rid}: {why}")
    return 0 if (res.diverged_at is None or swap is not None) else 1
