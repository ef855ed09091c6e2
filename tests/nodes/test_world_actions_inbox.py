"""The world's actions inbox: every robot the world may hold has its place, and a forger's
invented robot keys by the thousand never push a held robot's actions out; one look for overdue agents a pass."""

from __future__ import annotations

from iw_zenoh import keys
from iw_zenoh.messages import Actions, encode
from iw_zenoh.messages.wire import Outgoing
from iw_zenoh.sim.registry import MAX_ROBOTS
from tests.support.world_node import ROBOTS, TICK
from tests.support.world_node import deliver_actions as _deliver
from tests.support.world_node import lockstep_world as _world

INVENTED = 10_000  # ids the world does not hold, each on its own key


def test_the_actions_inbox_has_a_place_for_every_robot_the_world_may_hold() -> None:
    world, _ = _world()
    assert world.actions.keys_kept >= MAX_ROBOTS


def test_invented_robot_keys_do_not_push_the_held_robots_actions_out() -> None:
    world, bus = _world()
    box = bus.inboxes[keys.all_actions("t")]
    for rid in range(1_000, 1_000 + INVENTED):  # a forger fills the inbox first
        box.put((keys.actions("t", rid), encode(Actions(tick=TICK, robot_id=rid)), 0))
    for rid in range(1, ROBOTS + 1):
        _deliver(bus, rid)
    assert len(box) < 100 + ROBOTS  # the invented keys took a few places, not thousands
    world._take_actions(0)
    assert world.core.waiting_for(TICK) == 0  # every held robot's actions were taken
    assert box.lost > INVENTED - 100


def test_a_pass_of_the_world_looks_for_overdue_agents_once() -> None:
    world, _ = _world()
    calls: list[int] = []
    overdue = world.core.presence.overdue

    def counted(now_ns: int, grace_ns: int) -> list[Outgoing]:
        calls.append(now_ns)
        return overdue(now_ns, grace_ns)

    world.core.presence.overdue = counted  # type: ignore[method-assign]
    world.pump()  # the loop's inputs ...
    world.core.begin_tick(0)  # ... and its tick
    assert len(calls) == 1
