"""``iwz ctl``: steer a running simulation from a shell or a script, and hear the world answer.

Joins the bus as every one-shot command does (a client of the loopback router by default,
``--connect`` for another), asks the world for its description (``world/info``: no answer is
"no world"), publishes one :class:`~iw_zenoh.messages.Control` on ``world/control`` and waits
for the world's answering event (or, for a step, the tick to advance by N), within ``--timeout``.
Exit status: 0 done, 1 refused by the world, 3 no answer in time, 2 a bad command line or no bus,
4 a secured identity the policy beside it does not let send control (checked before anything is sent).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Callable, Sequence

from iw_zenoh import keys
from iw_zenoh.errors import IwError
from iw_zenoh.messages import Control, Event, Tick, WorldInfo, decode
from iw_zenoh.nodes.ctl_requests import COMMANDS, Answer, Request, answer_to, parse_request, resolve_move
from iw_zenoh.process.runtime import Process, start_role
from iw_zenoh.secure.diagnose import control_denied

__all__ = ["EXIT_DENIED", "EXIT_NO_ANSWER", "EXIT_REFUSED", "main"]

EXIT_REFUSED = 1  # the world answered: it cannot do it (bad-control, with its reason)
EXIT_NO_ANSWER = 3  # no world answered within the timeout
EXIT_DENIED = 4  # the identity's policy does not let it send control (the router would drop it unseen)
TIMEOUT_MAX_S = 86_400.0  # a day: the router's connect timeout is given to Zenoh in ms
POLL_S = 0.05  # how long one wait for an inbox lasts before the deadline is looked at again

EPILOG = """Commands:
  pause                     stop the ticks (the world answers 'paused' at its tick)
  resume | start            run again ('started')
  step [N]                  pause if running, then advance exactly N ticks (default 1)
  stop                      end the simulation ('stopped'; the world process exits)
  remove ID                 take robot ID out of the world ('removed')
  obstacle add NAME X0,Y0,X1,Y1[,HEIGHT]     a rectangular obstacle, corners in metres
  obstacle move NAME X0,Y0,X1,Y1[,HEIGHT]    give it new corners...
  obstacle move NAME X,Y                     ...or a new centre (its size and height kept)
  obstacle remove NAME

Examples:
  iwz ctl pause
  iwz ctl step 10 --json
  iwz ctl resume --sim demo
  iwz ctl remove 3
  iwz ctl obstacle add box 12,4,12.6,4.6 --height 0.8
  iwz ctl obstacle move box 14,5
  iwz ctl obstacle remove box
  iwz ctl stop --connect tcp/10.0.0.5:7447 --timeout 10

Exit status: 0 done, 1 the world refused (its reason is printed), 3 no world
answered within --timeout, 2 a bad command line or no bus (a refused certificate:
which and why), 4 the identity may not send control (by DIR/policy.toml beside
--identity DIR/NAME: only an operator may). --json prints one
object: ok, command, event, reason, tick, sim_time_s (and steps, from_tick
for a step)."""


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("command", choices=COMMANDS, help="what to ask the world (see below)")
    p.add_argument("words", nargs="*", help="the command's arguments: N, ID, or obstacle add|move|remove NAME ...")
    p.add_argument(
        "--timeout",
        type=float,
        default=5.0,
        metavar="S",
        help="wait this long for the router, then as long for the world's answer (default 5 s)",
    )
    p.add_argument(
        "--height", type=float, metavar="M", help="an obstacle's height in metres (default 1, kept on a move)"
    )
    p.add_argument("--json", action="store_true", help="print the outcome as one JSON object (for scripts)")


def _prepare(args: argparse.Namespace) -> Request:
    if not (math.isfinite(args.timeout) and 0 < args.timeout <= TIMEOUT_MAX_S):
        raise IwError(f"--timeout must be a positive number of seconds up to {TIMEOUT_MAX_S:g}, got {args.timeout:g}")
    req = parse_request(args.command, args.words, height_m=args.height)
    # a one-shot command waits for its router no longer than for its world (a --cfg given wins)
    args.cfg = [f'connect/timeout_ms:{{"client": {int(args.timeout * 1000)}}}', *args.cfg]
    return req


class _Session:
    """One command's exchange with the world: inboxes opened before anything is sent."""

    def __init__(self, proc: Process, timeout_s: float) -> None:
        self.proc = proc
        self.deadline = time.monotonic() + timeout_s
        self.timeout_s = timeout_s
        self.events = proc.io.inbox(keys.all_events(proc.sim))
        self.ticks = proc.io.inbox(keys.tick(proc.sim))
        self.last_tick: Tick | None = None

    def left(self) -> float:
        return self.deadline - time.monotonic()

    def info(self) -> WorldInfo | None:
        """The world's description, or ``None`` when no world answers in time."""
        while self.left() > 0:
            for data in self.proc.bus.query(keys.info(self.proc.sim), timeout_s=min(1.0, max(self.left(), 0.1))):
                try:
                    return decode(data, WorldInfo)
                except IwError:
                    continue
        return None

    def send(self, control: Control) -> None:
        self.proc.io.send(keys.control(self.proc.sim), control)

    def answer(self, req: Request) -> Answer | None:
        """The world's answering event to ``req``, or ``None`` at the deadline."""
        while self.left() > 0:
            got = self.events.get(timeout_s=min(POLL_S, max(self.left(), 0.0)))
            if got is None:
                continue
            try:
                ev = decode(got[1], Event)
            except IwError:
                continue
            a = answer_to(req, ev)
            if a is not None:
                return a
        return None

    def tick(self, pred: Callable[[Tick], bool] | None = None) -> Tick | None:
        """The next clock message (satisfying ``pred``), or ``None`` at the deadline."""
        while self.left() > 0:
            got = self.ticks.get(timeout_s=min(POLL_S, max(self.left(), 0.0)))
            if got is None:
                continue
            try:
                t = decode(got[1], Tick)
            except IwError:
                continue
            self.last_tick = t
            if pred is None or pred(t):
                return t
        return None


def _report(args: argparse.Namespace, result: dict[str, object], text: str) -> int:
    event = result.get("event")
    codes = {"bad-control": EXIT_REFUSED, "denied": EXIT_DENIED}
    code = 0 if result.get("ok") else codes.get(str(event), EXIT_NO_ANSWER)
    if args.json:
        print(json.dumps(result), flush=True)
    else:
        print(f"iwz ctl: {text}", flush=True)
    return code


def _secured(args: argparse.Namespace, what: str) -> str:
    """What a secured ctl adds to a silence: the router drops what the identity may not do, unseen."""
    if not getattr(args, "identity", None):
        return ""
    return f" (secured as {args.identity}: the router {what} without a word; is it an operator in the router's policy?)"


def _no_world(args: argparse.Namespace, s: _Session, req: Request) -> int:
    where = ", ".join(args.connect) or "the local router"
    why = (
        f"no world answered on {keys.info(s.proc.sim)} within {s.timeout_s:g} s (via {where}): start one "
        f"(iwz run SCENARIO, or iwz world MAP), or name its simulation (--sim) and its router (--connect)"
        + _secured(args, "sends an identity its policy does not name nothing")
    )
    return _report(args, {"ok": False, "command": req.what, "event": "", "reason": why}, why)


def _step(args: argparse.Namespace, s: _Session, req: Request, info: WorldInfo) -> int:
    """Pauses a running world (so the count starts at a known tick), steps, waits for the tick."""
    n = req.control.steps
    now = s.tick()
    if now is None:
        return _silent(args, s, req, info.tick, "the world sent no clock")
    start = max(info.tick, now.tick)
    if now.running:
        s.send(Control(command="pause"))
        paused = s.answer(Request(Control(command="pause"), "pause"))
        if paused is None:
            return _silent(args, s, req, start, "the world did not answer the pause before the step")
        start = paused.tick
    s.send(req.control)
    end = s.tick(lambda t: t.tick >= start + n)
    if end is None:
        return _silent(args, s, req, start, f"the world did not reach tick {start + n}")
    result = {
        "ok": True,
        "command": req.what,
        "event": "tick",
        "reason": f"stepped {n} tick{'s' if n > 1 else ''}",
        "steps": n,
        "from_tick": start,
        "tick": end.tick,
        "sim_time_s": end.sim_time_ns / 1e9,
    }
    return _report(args, result, f"stepped {n}: tick {start} -> {end.tick} (sim time {end.sim_time_ns / 1e9:.3f} s)")


def _silent(args: argparse.Namespace, s: _Session, req: Request, tick: int, what: str) -> int:
    last = s.last_tick.tick if s.last_tick is not None else tick
    why = (
        f"{req.what}: {what} within {s.timeout_s:g} s (last tick seen {last}); is every role running "
        "(without a collision process the world holds; in lock-step it waits for its agents)? "
        "A longer --timeout may help on a busy machine"
        + _secured(args, "drops a control from an identity that is no operator")
    )
    return _report(args, {"ok": False, "command": req.what, "event": "", "reason": why, "tick": last}, why)


def _run(proc: Process, req: Request) -> int:
    args = proc.args
    if getattr(args, "identity", None) and (denied := control_denied(args.identity)):
        return _report(args, {"ok": False, "command": req.what, "event": "denied", "reason": denied}, denied)
    s = _Session(proc, args.timeout)
    info = s.info()
    if info is None:
        return _no_world(args, s, req)
    try:
        req = resolve_move(req, {o.name: o for o in info.obstacles}, height_m=args.height)
    except ValueError as e:
        return _report(args, {"ok": False, "command": req.what, "event": "bad-control", "reason": str(e)}, str(e))
    if req.control.command == "step":
        return _step(args, s, req, info)
    s.send(req.control)
    a = s.answer(req)
    if a is None:
        return _silent(args, s, req, info.tick, "no answer from the world")
    reason = a.reason
    if not a.ok and req.control.command == "remove":
        reason += f" (robots in the world: {', '.join(str(r.id) for r in info.robots) or 'none'})"
    result = {
        "ok": a.ok,
        "command": req.what,
        "event": a.event,
        "reason": reason,
        "tick": a.tick,
        "sim_time_s": a.sim_time_ns / 1e9,
    }
    text = f"{a.event}: {reason} (tick {a.tick})" if a.ok else f"the world refused to {req.what}: {reason}"
    return _report(args, result, text)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz ctl``."""
    return start_role(
        argv,
        role="ctl",
        description=(
            "Steer a running simulation: pause, resume, step, stop, remove a robot, add, move or remove "
            "an obstacle. Publishes one control on iw/SIM/world/control and waits for the world's answer."
        ),
        epilog=EPILOG,
        arguments=_arguments,
        prepare=_prepare,
        run=_run,
    )
