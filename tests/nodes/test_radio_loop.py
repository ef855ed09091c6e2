"""The radio's loop: a tick goes out early (on a confirming verdict) only once the state of the
last early tick has checked it, whatever order the world's state and the next verdict arrive in."""

from __future__ import annotations

import time

from iw_zenoh import keys
from iw_zenoh.bus import Inbox
from iw_zenoh.messages import Event, EventKind, Proposed, RadioBatch, Say, Verdict, decode, encode
from iw_zenoh.nodes.radio import _Loop
from iw_zenoh.process.runtime import NodeIO
from iw_zenoh.viewer.sources import LocalBus
from tests.conftest import proposal_of, world_state

SIM = "s"


def _put(box: Inbox, key: str, data: bytes) -> None:
    box.put((key, data, time.time_ns()))


def test_the_next_tick_waits_for_the_state_of_the_last_early_one() -> None:
    out = Inbox()
    loop = _Loop(NodeIO(LocalBus(out), SIM, "radio", "radio"), SIM, None, early=True)
    _put(loop.states, keys.state(SIM), encode(world_state(1)))
    loop.once()
    for tick in (2, 3):
        _put(loop.says, keys.say(SIM, 1), encode(Say(robot_id=1, text=f"for {tick}")))
        _put(loop.proposals, keys.proposed(SIM), encode(proposal_of(world_state(tick))))
        _put(loop.verdicts, keys.verdict(SIM), encode(Verdict(tick=tick, revision=1, ids=[1], collided=[False])))
        loop.once()  # tick 2 goes out early; tick 3 not yet: the state of tick 2 has not come
    _put(loop.states, keys.state(SIM), encode(world_state(2)))  # it comes after verdict 3
    loop.once()
    batches = [decode(d[1], RadioBatch) for d in out.drain() if d[0] == keys.radio(SIM)]
    assert [(b.tick, [m.text for h in b.hear for m in h.messages]) for b in batches] == [
        (1, []),
        (2, ["for 2"]),
        (3, ["for 3"]),
    ]  # each tick once, in order, and tick 2 not delivered a second time by its late state


def test_a_forged_proposal_of_another_revision_without_distances_rolled_is_refused_not_raised() -> None:
    out = Inbox()
    loop = _Loop(NodeIO(LocalBus(out), SIM, "radio", "radio"), SIM, None, early=True)
    _put(loop.states, keys.state(SIM), encode(world_state(1)))
    loop.once()
    forged = proposal_of(world_state(2, revision=7))
    forged = Proposed(
        **{**{f: getattr(forged, f) for f in forged.__struct_fields__}, "rolled_left": [], "rolled_right": []}
    )
    _put(loop.proposals, keys.proposed(SIM), encode(forged))
    loop.once()  # raised ValueError in sim.early.state_from_proposal: the radio died
    refused = [decode(d[1], Event) for d in out.drain() if d[0] == keys.event(SIM, EventKind.BAD_MESSAGE)]
    assert [e.key for e in refused] == [keys.proposed(SIM)]
    assert "rolled_left" in refused[0].reason
    # the radio goes on: the world's own tick 2 is delivered
    _put(loop.states, keys.state(SIM), encode(world_state(2)))
    loop.once()
    assert [decode(d[1], RadioBatch).tick for d in out.drain() if d[0] == keys.radio(SIM)] == [2]
