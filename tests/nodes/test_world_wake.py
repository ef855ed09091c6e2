"""The lock-step world's wait for a tick's actions: its loop sleeps through the first robots'
actions and is woken by the delivery that may complete the tick (not by the poll, not by each
robot); a batch or a duplicate still wakes it, and every action is taken."""

from __future__ import annotations

from iw_zenoh.nodes.world import _World
from tests.support.world_node import ROBOTS, TICK
from tests.support.world_node import deliver_actions as _deliver
from tests.support.world_node import lockstep_world as _world

LONG_S = 30.0  # a wait the counting must cut short: reaching it fails the test, it does not slow it


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
