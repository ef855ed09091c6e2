"""Passage negotiation between chairs and a door, over the radio (so only chairs within range can
talk to a door). Pure: messages in, messages and decisions out; time is passed in.

Messages (ASCII, space separated, at most 100 bytes; a door and a chair are named by robot id)::

    ASK <door> <chair> <eta_s> <n>     chair -> door: let me through; I arrive in eta_s seconds
    GRANT <door> <chair> <n>           door -> chair: the door is open and the doorway yours
    WAIT <door> <chair> <place> <n>    door -> chair: stop short of the door; place in the queue
                                       (0: you are next, the door is opening or the doorway is busy)
    REFUSE <door> <chair> <why> <n>    door -> chair: not now (queue full, ...); ask again later
    PASSED <door> <chair>              chair -> door: I am through; the doorway is free

A revolving door (``iw_zenoh/core/revolving.py``) also needs to know which side a chair comes
from, and carries it through in turn::

    ASK <door> <chair> <eta_s> <n> <side>   side +1 or -1: along the door's axis or against it
    IN <door> <chair>                  chair -> door: I am in the sector, turned: carry me
    TURN <door> <chair> <done> <rate> <t>   door -> chair: of the half turn, done degrees at
                                       sim time t s, turning rate deg/s (180 and 0: delivered)

``n`` is the chair's request counter, echoed so a chair can tell a fresh answer from a stale one.

Rules. A chair asks about once a second while it wants the door (radio messages may be lost; a
lost ASK or answer is repaired by the next). The door keeps a queue in order of arrival time
(now + eta when first heard; ties by chair id, so two chairs racing in one tick are ordered the
same way every run). One chair holds the doorway at a time: the head of the queue, granted once
the door is fully open. The door stays open while a holder is granted, and releases the holder
when it says PASSED, or when it has not been heard for ``silent_s`` (a chair that vanished or
lost its radio), or after ``hold_s`` in all. A queued chair not heard for ``silent_s`` leaves the
queue. A chair told to WAIT (or refused, or not answered) stops at a safe distance from the door
and never drives through a doorway it does not hold. The door closes (by its own state machine,
which never shuts on someone it detects) only when nobody holds or waits.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["Answer", "Arbiter", "Ask", "Client", "In", "Passed", "Turn", "join", "parse", "parse_all"]

MAX_BYTES = 100


@dataclass(frozen=True)
class Ask:
    """ASK: a chair asks a door for passage (from ``side`` of a revolving door; 0: not said)."""

    door: int
    chair: int
    eta_s: float
    n: int
    side: int = 0

    def text(self) -> str:
        """The radio text."""
        more = f" {self.side:+d}" if self.side else ""
        return f"ASK {self.door} {self.chair} {self.eta_s:.1f} {self.n}{more}"


@dataclass(frozen=True)
class Answer:
    """GRANT, WAIT or REFUSE: a door answers a chair."""

    kind: str  # GRANT, WAIT or REFUSE
    door: int
    chair: int
    n: int
    place: int = 0
    why: str = ""

    def text(self) -> str:
        """The radio text."""
        if self.kind == "GRANT":
            return f"GRANT {self.door} {self.chair} {self.n}"
        if self.kind == "WAIT":
            return f"WAIT {self.door} {self.chair} {self.place} {self.n}"
        return f"REFUSE {self.door} {self.chair} {self.why} {self.n}"


@dataclass(frozen=True)
class Passed:
    """PASSED: a chair is through."""

    door: int
    chair: int

    def text(self) -> str:
        """The radio text."""
        return f"PASSED {self.door} {self.chair}"


@dataclass(frozen=True)
class In:
    """IN: a chair is in a revolving door's sector, ready to be carried."""

    door: int
    chair: int

    def text(self) -> str:
        """The radio text."""
        return f"IN {self.door} {self.chair}"


@dataclass(frozen=True)
class Turn:
    """TURN: how far a revolving door has carried a chair, and how fast it turns."""

    door: int
    chair: int
    done_deg: float
    rate_dps: float
    t_s: float

    def text(self) -> str:
        """The radio text."""
        return f"TURN {self.door} {self.chair} {self.done_deg:.2f} {self.rate_dps:.3f} {self.t_s:.2f}"


Message = Ask | Answer | Passed | In | Turn


def parse(text: str) -> Message | None:
    """A protocol message, or None for anything else (other talk on the radio, garbage)."""
    p = text.split()
    try:
        if p[0] == "ASK" and len(p) in (5, 6):
            side = int(p[5]) if len(p) == 6 else 0
            return Ask(int(p[1]), int(p[2]), float(p[3]), int(p[4]), side) if side in (-1, 0, 1) else None
        if p[0] == "IN" and len(p) == 3:
            return In(int(p[1]), int(p[2]))
        if p[0] == "TURN" and len(p) == 6:
            return Turn(int(p[1]), int(p[2]), float(p[3]), float(p[4]), float(p[5]))
        if p[0] == "GRANT" and len(p) == 4:
            return Answer("GRANT", int(p[1]), int(p[2]), int(p[3]))
        if p[0] == "WAIT" and len(p) == 5:
            return Answer("WAIT", int(p[1]), int(p[2]), int(p[4]), place=int(p[3]))
        if p[0] == "REFUSE" and len(p) == 5:
            return Answer("REFUSE", int(p[1]), int(p[2]), int(p[4]), why=p[3])
        if p[0] == "PASSED" and len(p) == 3:
            return Passed(int(p[1]), int(p[2]))
    except (ValueError, IndexError):
        return None
    return None


def parse_all(text: str) -> list[Message]:
    """Every protocol message in one radio text (a door packs several answers, ``;`` apart)."""
    out = []
    for part in text.split(";"):
        m = parse(part) if part.strip() else None
        if m is not None:
            out.append(m)
    return out


def join(texts: list[str]) -> tuple[str | None, list[str]]:
    """Packs texts into one radio message of at most 100 bytes; returns it and what did not fit."""
    packed: list[str] = []
    size = 0
    for i, t in enumerate(texts):
        extra = len(t.encode()) + (1 if packed else 0)
        if size + extra > MAX_BYTES:
            return ";".join(packed) or None, texts[i:]
        packed.append(t)
        size += extra
    return (";".join(packed) or None), []


@dataclass
class _Entry:
    chair: int
    arrival_s: float
    heard_s: float
    n: int
    side: int = 0


@dataclass
class Arbiter:
    """The door's side.

    Args:
        door: The door's robot id.
        silent_s: A chair not heard this long leaves the queue (or loses the doorway).
        hold_s: A holder loses the doorway after this long in all.
        max_queue: Refuse beyond this many waiting chairs.
    """

    door: int
    silent_s: float = 3.0
    hold_s: float = 30.0
    max_queue: int = 6
    queue: list[_Entry] = field(default_factory=list)
    holder: int | None = None
    held_since_s: float = 0.0
    log: list[str] = field(default_factory=list)

    def _expire(self, now_s: float) -> None:
        for e in list(self.queue):
            if now_s - e.heard_s > self.silent_s:
                self.queue.remove(e)
                self.log.append(f"{now_s:.1f} chair {e.chair} silent: dropped")
        if self.holder is not None and (
            all(e.chair != self.holder for e in self.queue) or now_s - self.held_since_s > self.hold_s
        ):
            self.log.append(f"{now_s:.1f} chair {self.holder} released (silent or too long)")
            self.queue = [e for e in self.queue if e.chair != self.holder]
            self.holder = None

    def step(self, heard: list[Message], now_s: float, door_open: bool) -> list[Answer]:
        """Takes this tick's messages; returns the answers to say (one per asking chair)."""
        asks = sorted((m for m in heard if isinstance(m, Ask) and m.door == self.door), key=lambda a: a.chair)
        for m in heard:
            if isinstance(m, Passed) and m.door == self.door:
                self.queue = [e for e in self.queue if e.chair != m.chair]
                if self.holder == m.chair:
                    self.holder = None
                    self.log.append(f"{now_s:.1f} chair {m.chair} passed")
        self._expire(now_s)  # before this tick's asks: a chair asking now is not silent
        refused: dict[int, Ask] = {}
        for a in asks:
            e = next((e for e in self.queue if e.chair == a.chair), None)
            if e is not None:
                e.heard_s, e.n = now_s, a.n
            elif len(self.queue) >= self.max_queue:
                refused[a.chair] = a
            else:
                self.queue.append(_Entry(a.chair, now_s + max(0.0, a.eta_s), now_s, a.n, a.side))
        # the holder keeps its place at the head; the rest in order of arrival, then id
        self.queue.sort(key=lambda e: (e.chair != self.holder, e.arrival_s, e.chair))
        if self.holder is None and self.queue and door_open:
            self.holder = self.queue[0].chair
            self.held_since_s = now_s
            self.log.append(f"{now_s:.1f} chair {self.holder} granted")
        out: list[Answer] = []
        for a in asks:
            if a.chair in refused:
                out.append(Answer("REFUSE", self.door, a.chair, a.n, why="full"))
            elif a.chair == self.holder:
                out.append(Answer("GRANT", self.door, a.chair, a.n))
            else:
                place = next(i for i, e in enumerate(self.queue) if e.chair == a.chair)
                out.append(Answer("WAIT", self.door, a.chair, a.n, place=place - (1 if self.holder is not None else 0)))
        return out

    @property
    def wanted(self) -> bool:
        """Whether the door should be open (someone holds or waits)."""
        return bool(self.queue) or self.holder is not None


@dataclass
class Client:
    """A chair's side, for one door.

    Args:
        door: The door's id.
        chair: This chair's id.
        ask_every_s: Repeat the ASK this often while wanting the door.
        grant_life_s: A GRANT not renewed this long is no longer trusted.
    """

    door: int
    chair: int
    ask_every_s: float = 1.0
    grant_life_s: float = 2.5
    n: int = 0
    granted_at_s: float = -1e9
    last_ask_s: float = -1e9
    last_answer: Answer | None = None
    passed_left: int = 0
    side: int = 0

    def granted(self, now_s: float) -> bool:
        """Whether this chair may drive through the doorway now."""
        return now_s - self.granted_at_s <= self.grant_life_s

    def hear(self, heard: list[Message], now_s: float) -> None:
        """Takes the door's answers to this chair."""
        for m in heard:
            if isinstance(m, Answer) and m.door == self.door and m.chair == self.chair and m.n == self.n:
                self.last_answer = m
                if m.kind == "GRANT":
                    self.granted_at_s = now_s
                else:
                    self.granted_at_s = -1e9

    def say(self, now_s: float, *, wants: bool, eta_s: float, through: bool) -> str | None:
        """What to say this tick: an ASK while wanting the door, PASSED (three times, as the
        radio may lose one) once through, or nothing."""
        if through and self.passed_left == 0 and self.n > 0:
            self.passed_left = 3
            self.granted_at_s = -1e9
        if self.passed_left > 0:
            self.passed_left -= 1
            if self.passed_left == 0:
                self.n = 0  # done: a later visit asks afresh
            return Passed(self.door, self.chair).text()
        if wants and now_s - self.last_ask_s >= self.ask_every_s:
            self.last_ask_s = now_s
            if self.n == 0 or self.last_answer is not None:
                self.n += 1
            self.last_answer = None
            return Ask(self.door, self.chair, eta_s, self.n, self.side).text()
        return None
