"""The world's description as other nodes keep it: asked for, or taken as the world publishes it."""

from __future__ import annotations

import msgspec
import pytest

from iw_zenoh.core.modes import Profile
from iw_zenoh.messages import encode
from iw_zenoh.nodes.info import InfoCache
from iw_zenoh.sim.collision import CollisionNode
from tests.support.fakes import FakeBus
from tests.support.infos import world_info as _info


class _CountingBus(FakeBus):
    def __init__(self) -> None:
        super().__init__()
        self.queries = 0

    def query(self, key: str, payload: bytes = b"", timeout_s: float = 2.0) -> list[bytes]:
        self.queries += 1
        return super().query(key, payload, timeout_s)


def test_a_published_description_is_the_view_without_asking_the_world() -> None:
    bus = _CountingBus()
    cache = InfoCache(bus, "s")
    view = cache.take(encode(_info(3, robots=1)))
    assert view is not None
    assert list(view.specs) == [1]
    assert cache.get(3) is view
    assert bus.queries == 0


def test_an_older_or_refused_publication_is_not_taken() -> None:
    cache = InfoCache(FakeBus(), "s")
    assert cache.take(encode(_info(3))) is not None
    assert cache.take(encode(_info(2, robots=1))) is None
    assert cache.take(b"{not json") is None
    assert cache.view is not None
    assert cache.view.info.revision == 3


def test_a_newer_revision_than_taken_is_asked_for() -> None:
    bus = _CountingBus()
    bus.info.append(encode(_info(5, robots=2)))
    cache = InfoCache(bus, "s")
    cache.take(encode(_info(4)))
    view = cache.get(5)
    assert view is not None
    assert view.info.revision == 5
    assert bus.queries == 1


@pytest.mark.parametrize("profile", list(Profile))
def test_warming_builds_what_the_first_check_of_a_revision_needs(profile: Profile) -> None:
    view = InfoCache(FakeBus(), "s").take(encode(msgspec.structs.replace(_info(1, robots=2), profile=profile)))
    assert view is not None
    CollisionNode().warm(view)
    assert "segments" in view.scene.__dict__  # the lab's geometry, built on first use (cached_property)
    assert (1, 2) in view._bodies  # the roster's bodies, in the world's order


def test_warming_an_empty_world_checks_nothing() -> None:
    view = InfoCache(FakeBus(), "s").take(encode(_info(1)))
    assert view is not None
    CollisionNode().warm(view)
    assert view._bodies == {}


def test_a_world_started_afresh_is_taken_though_its_revision_is_older() -> None:
    bus = _CountingBus()
    cache = InfoCache(bus, "s")
    assert cache.take(encode(_info(9, robots=1))) is not None  # the world that was
    bus.info.append(encode(_info(2, robots=2)))  # a new world, started by hand, at revision 2
    view = cache.get(2)
    assert view is not None
    assert view.info.revision == 2
    assert list(view.specs) == [1, 2]
    assert cache.get(2) is view
    assert bus.queries == 1


def test_a_late_message_of_an_older_revision_keeps_the_view() -> None:
    bus = _CountingBus()
    cache = InfoCache(bus, "s")
    kept = cache.take(encode(_info(5, robots=1)))
    bus.info.append(encode(_info(5, robots=1)))  # the world is still at 5
    assert cache.get(4) is kept
    assert cache.view is kept


def test_of_several_answers_the_one_at_the_revision_asked_serves() -> None:
    bus = _CountingBus()
    bus.info += [encode(_info(0)), encode(_info(1, robots=1))]  # another world (revision 0) answered too
    cache = InfoCache(bus, "s")
    view = cache.get(1)
    assert view is not None
    assert view.info.revision == 1
    assert cache.why == ""


def test_an_answer_older_than_asked_says_so() -> None:
    bus = _CountingBus()
    bus.info.append(encode(_info(0)))
    cache = InfoCache(bus, "s")
    assert cache.get(1) is None
    assert cache.why == "the world answered revision 0, older than 1"


def test_no_answer_says_so() -> None:
    cache = InfoCache(_CountingBus(), "s")
    assert cache.get(1) is None
    assert cache.why.startswith("no answer to iw/s/world/info")


@pytest.mark.parametrize(
    "hostile",
    [
        b"{not json",
        b"\xff\xfe\x00",
        b'{"revision": "un", "lab": {}, "period_ns": 1}',
        b'{"revision": NaN}',
        ("{" + '"name": "' + "é" * 200_000 + '"}').encode(),
    ],
)
def test_a_hostile_answer_beside_the_worlds_is_refused_and_the_worlds_serves(hostile: bytes) -> None:
    bus = _CountingBus()
    bus.info += [hostile, encode(_info(2, robots=1)), hostile]
    cache = InfoCache(bus, "s")
    view = cache.get(2)
    assert view is not None
    assert view.info.revision == 2
    assert cache.why == ""


def test_only_hostile_answers_say_they_were_refused() -> None:
    bus = _CountingBus()
    bus.info += [b"{not json", b"\x00" * 1000]
    cache = InfoCache(bus, "s")
    assert cache.get(1) is None
    assert cache.why == "2 answers to iw/s/world/info, none usable (refused above)"
