"""The lock-step world's wait for a tick's actions: its loop sleeps through the first robots'
actions and is woken by the delivery that may complete the tick (not by the poll, not by each
robot); a batch or a duplicate still wakes it, and every action is taken."""

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
LONG_S = 30.0  # a wait the counting must cut short: reaching it fails the test, it does not slow it


class _Quiet:
    def poll(self) -> list[PendingQuery]:
        return []

    def undeclare(self) -> None:
        pass


class _Bus(FakeBus):
    """Keeps each subscription's inbox, so the test delivers as the network would."""

    def __init__(self) -> None:
        super().__init__()
        self.inboxes: dict[str, Inbox] = {}

    def subscribe(self, key_expr: str, inbox: Inbox, *, ordered: bool = False) -> Handle:
        self.inboxes[key_expr] = inbox
        return super().subscribe(key_expr, inbox, ordered=ordered)

    def serve(self, key: str) -> QueryInbox:
        return _Quiet()


class _Clock:
    """Time stands still: only a wake-up ends a wait, never the deadline."""

    def now_ns(self) -> int:
        return 0

    def wall_ns(self) -> int:
        return 0

    def wait(self, event: threading.Event, timeout_s: float) -> bool:
        return event.wait(timeout_s)


def _world() -> tuple[_World, _Bus]:
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
    bus = _Bus()
    return _World(bus, core, _Clock(), "world"), bus


def _deliver(bus: _Bus, robot_id: int) -> None:
    data = encode(Actions(tick=TICK, robot_id=robot_id))
    bus.inboxes[keys.all_actions("t")].put((keys.actions("t", robot_id), data, 0))


def _waits(world: _World, on_wait: list[object]) -> list[bool]:
    """Runs the world's wait for tick ``TICK``'s actions; each time its loop sleeps, the next of
    ``on_wait`` delivers (as the network would, meanwhile); returns, per sleep, whether a
    delivery woke it (False: only the long timeout would have)."""
    woken: list[bool] = []
    todo = list(on_wait)

    def wait(timeout_s: float) -> None:
        step = todo.pop(0)
        assert callable(step)
        step()
        woken.append(world.io.wake.wait(LONG_S))
        world.io.wake.clear()

    world.io.wait = wait  # type: ignore[method-assign]
    world.actions_wake.hold()  # as the loop does before the proposal goes out
    world._await_actions(None)
    assert not world.core.waiting(TICK)
    assert not world.actions_wake.held  # released: real time, registration... wake at once again
    return woken


def test_the_first_robots_actions_do_not_wake_the_loop_the_last_one_does() -> None:
    world, bus = _world()

    def arrive() -> None:
        for rid in range(1, ROBOTS):
            _deliver(bus, rid)
            assert not world.io.wake.is_set()
        _deliver(bus, ROBOTS)

    assert _waits(world, [arrive]) == [True]  # one wake-up for the tick, by the last robot


def test_actions_that_came_before_the_wait_are_counted() -> None:
    world, bus = _world()
    world.actions_wake.hold()  # the proposal goes out...
    _deliver(bus, 1)  # ... and the first actions come while the tick's verdict is awaited, say
    assert not world.io.wake.is_set()  # held: nobody woken for it

    def rest() -> None:
        _deliver(bus, 2)
        assert not world.io.wake.is_set()
        _deliver(bus, 3)

    assert _waits(world, [rest]) == [True]


def test_a_duplicate_wakes_the_loop_early_and_the_tick_still_completes() -> None:
    world, bus = _world()

    def twice() -> None:
        _deliver(bus, 1)
        _deliver(bus, 1)
        _deliver(bus, 2)  # three deliveries, two robots: the loop wakes and finds robot 3 awaited

    assert _waits(world, [twice, lambda: _deliver(bus, 3)]) == [True, True]
