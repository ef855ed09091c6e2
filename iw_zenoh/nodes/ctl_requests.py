"""What ``iwz ctl`` asks the world, and which of the world's answers settles it (no I/O).

A command line's words become a :class:`Request`: the :class:`~iw_zenoh.messages.Control` to
publish and what to wait for. The world answers every control it takes with an event (``started``,
``paused``, ``stopped``, ``removed``, ``obstacle``) or refuses it (``bad-control``, with its
reason); a step has no event of its own: it is done when the tick has advanced by N.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import msgspec

from iw_zenoh import keys
from iw_zenoh.errors import DecodeError
from iw_zenoh.messages import Control, Event, EventKind, Obstacle, ObstacleData, event_payload
from iw_zenoh.messages.wire import INT64_MAX

__all__ = ["COMMANDS", "Answer", "Request", "answer_to", "parse_request", "resolve_move"]

COMMANDS = ("pause", "resume", "start", "step", "stop", "remove", "obstacle")
ObstacleCommand = Literal["add_obstacle", "move_obstacle", "remove_obstacle"]
OBSTACLE_VERBS: dict[str, ObstacleCommand] = {
    "add": "add_obstacle",
    "move": "move_obstacle",
    "remove": "remove_obstacle",
}
_PLAIN: dict[str, Literal["start", "pause", "stop"]] = {
    "pause": "pause",
    "resume": "start",
    "start": "start",
    "stop": "stop",
}
DEFAULT_HEIGHT_M = 1.0  # an obstacle's height when none is given (as the world's --obstacle)
_DONE = {
    "start": EventKind.STARTED,
    "pause": EventKind.PAUSED,
    "stop": EventKind.STOPPED,
    "remove": EventKind.REMOVED,
    "add_obstacle": EventKind.OBSTACLE,
    "move_obstacle": EventKind.OBSTACLE,
    "remove_obstacle": EventKind.OBSTACLE,
}


@dataclass(frozen=True)
class Request:
    """One command for the world.

    Attributes:
        control: What to publish on ``world/control``.
        what: The command as people say it (``pause``, ``step 3``, ``remove robot 2``...).
        move_to: For ``obstacle move NAME X,Y``: the new centre (m); the obstacle's size and
            height come from the world (:func:`resolve_move`) before ``control`` is sent.
    """

    control: Control
    what: str
    move_to: tuple[float, float] | None = None


@dataclass(frozen=True)
class Answer:
    """The world's answer to a request.

    Attributes:
        ok: Done (False: refused).
        event: The answering event's kind (``paused``, ``bad-control``...).
        reason: What the world said.
        tick: The tick it answered at.
        sim_time_ns: The simulation time it answered at (ns).
    """

    ok: bool
    event: str
    reason: str
    tick: int
    sim_time_ns: int


def _numbers(text: str, what: str, counts: tuple[int, ...]) -> list[float]:
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        v = []
    if len(v) not in counts or not all(math.isfinite(x) for x in v):
        raise ValueError(
            f"{what}: expected {' or '.join(str(c) for c in counts)} numbers separated by commas, each finite, "
            f"got {text!r}"
        )
    return v


def _height(h: float | None, what: str) -> None:
    if h is not None and not (math.isfinite(h) and h > 0):
        raise ValueError(f"{what}: an obstacle's height is a positive number of metres, got {h:g}")


def _count(words: Sequence[str], least: int) -> int | None:
    """The one integer of ``words`` when it is in least..INT64_MAX (what the wire carries), else None."""
    if len(words) != 1 or not words[0].isdigit():
        return None
    n = int(words[0])
    return n if least <= n <= INT64_MAX else None


def _obstacle(words: Sequence[str], height_m: float | None) -> Request:
    if not words or words[0] not in OBSTACLE_VERBS:
        raise ValueError(f"obstacle takes add, move or remove, got {' '.join(words) or 'nothing'!r}")
    verb, rest = words[0], list(words[1:])
    command = OBSTACLE_VERBS[verb]
    if verb == "remove":
        if len(rest) != 1:
            raise ValueError(f"obstacle remove takes one NAME, got {' '.join(rest) or 'nothing'!r}")
        ob = Obstacle(name=rest[0], x0=0.0, y0=0.0, x1=0.0, y1=0.0)
        return Request(Control(command=command, obstacle=ob), f"remove obstacle {rest[0]!r}")
    if len(rest) != 2:
        form = "X0,Y0,X1,Y1[,HEIGHT] or X,Y (a new centre)" if verb == "move" else "X0,Y0,X1,Y1[,HEIGHT]"
        raise ValueError(f"obstacle {verb} takes NAME {form}, got {' '.join(rest) or 'nothing'!r}")
    name, corners = rest
    if not name:
        raise ValueError(f"obstacle {verb} takes a NAME that is not empty")
    _height(height_m, f"obstacle {verb} {name}")
    v = _numbers(corners, f"obstacle {verb} {name}", (2, 4, 5) if verb == "move" else (4, 5))
    if len(v) == 2:
        ob = Obstacle(name=name, x0=v[0], y0=v[1], x1=v[0], y1=v[1], height=height_m or DEFAULT_HEIGHT_M)
        return Request(Control(command=command, obstacle=ob), f"move obstacle {name!r}", move_to=(v[0], v[1]))
    h = v[4] if len(v) == 5 else height_m or DEFAULT_HEIGHT_M
    _height(h, f"obstacle {verb} {name}")
    ob = Obstacle(name=name, x0=v[0], y0=v[1], x1=v[2], y1=v[3], height=h)
    return Request(Control(command=command, obstacle=ob), f"{verb} obstacle {name!r}")


def parse_request(command: str, words: Sequence[str], *, height_m: float | None = None) -> Request:
    """The request a command line asks for.

    Args:
        command: One of :data:`COMMANDS`.
        words: What follows it (``step 3``: ``["3"]``; ``obstacle add A 1,2,3,4``: ``["add", "A", "1,2,3,4"]``).
        height_m: An obstacle's height when its numbers give none (m; ``None``: 1 m, or kept on a move).

    Returns:
        The request.

    Raises:
        ValueError: Saying what the command takes.
    """
    plain = _PLAIN.get(command)
    if plain is not None:
        if words:
            raise ValueError(f"{command} takes nothing more, got {' '.join(words)!r}")
        return Request(Control(command=plain), command)
    if command == "step":
        n = _count(words, 1) if words else 1
        if n is None:
            raise ValueError(f"step takes one count N >= 1 (default 1), got {' '.join(words)!r}")
        return Request(Control(command="step", steps=n), f"step {n}")
    if command == "remove":
        rid = _count(words, 0)
        if rid is None:
            raise ValueError(f"remove takes one robot ID (an integer), got {' '.join(words) or 'nothing'!r}")
        return Request(Control(command="remove", robot_id=rid), f"remove robot {rid}")
    if command == "obstacle":
        return _obstacle(words, height_m)
    raise ValueError(f"no command {command!r}; one of {', '.join(COMMANDS)}")


def resolve_move(req: Request, obstacles: Mapping[str, Obstacle], *, height_m: float | None = None) -> Request:
    """A move to a new centre made whole: the obstacle's size (and height, unless given) kept.

    Args:
        req: The request (returned as it is unless it moves an obstacle to a centre).
        obstacles: The world's obstacles by name (from its ``world/info``).
        height_m: A new height (``None``: the obstacle's own).

    Returns:
        The request with its full obstacle.

    Raises:
        ValueError: No obstacle of that name in the world (naming those there are).
    """
    ob = req.control.obstacle
    if req.move_to is None or ob is None:
        return req
    now = obstacles.get(ob.name)
    if now is None:
        there = ", ".join(repr(n) for n in sorted(obstacles)) or "none"
        raise ValueError(f"no obstacle named {ob.name!r} to move (the world has {there})")
    x, y = req.move_to
    hw, hh = abs(now.x1 - now.x0) / 2, abs(now.y1 - now.y0) / 2
    moved = msgspec.structs.replace(
        now, x0=x - hw, y0=y - hh, x1=x + hw, y1=y + hh, height=now.height if height_m is None else height_m
    )
    return Request(msgspec.structs.replace(req.control, obstacle=moved), req.what)


def _mine(req: Request, ev: Event) -> bool:
    """Whether an event of the answering kind is about this request (its robot, its obstacle)."""
    c = req.control
    if c.command == "remove":
        return ev.robot_id == c.robot_id
    if c.obstacle is not None:
        if ev.kind == EventKind.BAD_CONTROL:
            return repr(c.obstacle.name) in ev.reason or keys.is_control(ev.key)
        try:
            return event_payload(ev, ObstacleData).name == c.obstacle.name and ev.reason.startswith(c.command)
        except (TypeError, DecodeError):
            return False
    return True


def answer_to(req: Request, ev: Event) -> Answer | None:
    """The world's answer to ``req`` if ``ev`` is it (``None``: some other event).

    A refusal (``bad-control``) is taken as the answer when it names this request's robot or
    obstacle (any refusal for a command that has neither): the world takes controls one at a
    time, so a refusal that comes after the request and fits it is its answer.

    Args:
        req: What was asked (not a step: a step has no answering event).
        ev: An event the world published after the request went out.

    Returns:
        The answer, or ``None``.
    """
    done = _DONE.get(req.control.command)
    if ev.kind not in (done, EventKind.BAD_CONTROL) or ev.source not in ("world", ""):
        return None
    if not _mine(req, ev):
        return None
    return Answer(
        ok=ev.kind != EventKind.BAD_CONTROL,
        event=str(ev.kind),
        reason=ev.reason,
        tick=ev.tick,
        sim_time_ns=ev.sim_time_ns,
    )
