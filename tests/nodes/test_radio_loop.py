"""The radio's loop: a tick goes out early (on a confirming verdict) only once the state of the
last early tick has checked it, whatever order the world's state and the next verdict arrive in."""

from __future__ import annotations

import time

from iw_zenoh import keys
from iw_zenoh.bus import Inbox
from iw_zenoh.messages import RadioBatch, Say, Verdict, decode, encode
from iw_zenoh.nodes.radio import _Loop
from iw_zenoh.runtime import NodeIO
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
