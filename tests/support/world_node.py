"""A lock-step world node on a fake bus that keeps its inboxes, waiting for its first tick's actions, and those actions delivered."""

from __future__ import annotations

import threading

from iw_zenoh import keys
from iw_zenoh.bus import Handle, Inbox, PendingQuery, QueryInbox
from iw_zenoh.core.lab import Grid, GridPosition, Lab
from iw_zenoh.messages import Actions, Proposed, RegisterRequest, RobotSpecMsg, Verdict, encode
from iw_zenoh.nodes.world import _World
from iw_zenoh.sim.config import WorldConfig
from iw_zenoh.sim.world import WorldCore
from tests.support.builders import box_wall
from tests.support.fakes import FakeBus

ROBOTS = 3


TICK = 1  # the first tick stepped: its actions are awaited


class QuietQueries:
    def poll(self) -> list[PendingQuery]:
        return []

    def undeclare(self) -> None:
        pass


class DeliveringBus(FakeBus):
    """Keeps each subscription's inbox, so the test delivers as the network would."""

    def __init__(self) -> None:
        super().__init__()
        self.inboxes: dict[str, Inbox] = {}

    def subscribe(self, key_expr: str, inbox: Inbox, *, ordered: bool = False) -> Handle:
        self.inboxes[key_expr] = inbox
        return super().subscribe(key_expr, inbox, ordered=ordered)

    def serve(self, key: str) -> QueryInbox:
        return QuietQueries()


class StillClock:
    """Time stands still: only a wake-up ends a wait, never the deadline."""

    def now_ns(self) -> int:
        return 0

    def wall_ns(self) -> int:
        return 0

    def wait(self, event: threading.Event, timeout_s: float) -> bool:
        return event.wait(timeout_s)


def lockstep_world() -> tuple[_World, DeliveringBus]:
    lab = Lab("t", 20.0, 10.0, (box_wall(9.0, 0.0, 10.0, 3.0),))
    grid = Grid(tuple(GridPosition(2 + 3 * i, 5, 0) for i in range(ROBOTS)))
    core = WorldCore(WorldConfig(sim="t", mode="lockstep", lockstep_timeout_ms=1e9), lab, grid)  # type: ignore[arg-type]
    for i in range(ROBOTS):
        core.register(RegisterRequest(spec=RobotSpecMsg(name=f"r{i}"), agent="ag"), 0)
    for role, name in (("agent", "ag"), ("collision", "c"), ("sensors", "s")):
        core.on_alive(role, name, True, 0)
    prop = next(m for _, m in core.begin_tick(0) if isinstance(m, Proposed))
    core.finish_tick(Verdict(tick=prop.tick, revision=prop.revision, ids=prop.ids, collided=[False] * ROBOTS))
    assert core.tick == TICK
    assert core.waiting_for(TICK) == ROBOTS
    bus = DeliveringBus()
    return _World(bus, core, StillClock(), "world"), bus


def deliver_actions(bus: DeliveringBus, robot_id: int) -> None:
    data = encode(Actions(tick=TICK, robot_id=robot_id))
    bus.inboxes[keys.all_actions("t")].put((keys.actions("t", robot_id), data, 0))
