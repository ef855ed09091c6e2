"""A recorded world state, the message recording tests write."""

from __future__ import annotations

from iw_zenoh.messages import WorldState, encode


def recorded_state(tick: int) -> bytes:
    return encode(
        WorldState(
            tick=tick,
            sim_time_ns=tick * 100_000_000,
            revision=1,
            ids=[1],
            x=[1.0 * tick],
            y=[2.0],
            heading=[0.0],
            collided=[False],
            rolled_left=[0.0],
            rolled_right=[0.0],
            speed=[0.0],
        )
    )
