"""The world publishes its description again when a process that keeps it comes alive: a
collision or sensors process that joined after the last revision was published (its kernels
warmed, on a loaded machine, while a bridge registered) had only the world/info query, and when
that brought nothing usable it held every robot for the rest of the run."""

from __future__ import annotations

from iw_zenoh import keys
from iw_zenoh.messages import WorldInfo, decode
from iw_zenoh.nodes.info import InfoCache
from tests.support.fakes import FakeBus
from tests.support.world_node import lockstep_world


def _infos(published: list[tuple[str, bytes]]) -> list[bytes]:
    return [data for key, data in published if key == keys.info("t")]


def test_a_collision_process_that_comes_alive_is_sent_the_description_again() -> None:
    world, bus = lockstep_world()
    world._publish_info()
    world._publish_info()  # nothing changed: not again
    assert len(_infos(bus.published)) == 1
    world._on_alive(keys.alive("t", "collision", "late"), True)
    world.pump()
    world._publish_info()
    again = _infos(bus.published)
    assert len(again) == 2
    revision = decode(again[-1], WorldInfo).revision
    assert revision == world.core.revision

    late = InfoCache(FakeBus(), "t")  # its world/info query brings nothing (no answer reached it)
    assert late.get(revision) is None
    assert "no answer" in late.why
    late.take(again[-1])  # what it heard on the key it subscribed to before its token
    view = late.get(revision)
    assert view is not None
    assert view.info.revision == revision


def test_an_agent_coming_alive_does_not_republish_it() -> None:
    world, bus = lockstep_world()
    world._publish_info()
    world._on_alive(keys.alive("t", "agent", "another"), True)
    world.pump()
    world._publish_info()
    assert len(_infos(bus.published)) == 1
