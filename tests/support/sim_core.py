"""A WorldCore on a small lab, the kinds of events it said, one tick stepped."""

from __future__ import annotations

from iw_zenoh.core.lab import Grid, GridPosition, Lab
from iw_zenoh.messages import (
    Event,
    Proposed,
    Verdict,
    WorldState,
)
from iw_zenoh.sim.config import WorldConfig
from iw_zenoh.sim.world import WorldCore
from tests.support.builders import box_wall


def world_core(**kw: object) -> WorldCore:
    lab = Lab("t", 20.0, 10.0, (box_wall(9.0, 0.0, 10.0, 3.0),))
    grid = Grid((GridPosition(2, 5, 0), GridPosition(5, 5, 0)))
    return WorldCore(WorldConfig(sim="t", **kw), lab, grid)  # type: ignore[arg-type]


def event_kinds(out: list[tuple[str, object]]) -> list[str]:
    return [m.kind for _, m in out if isinstance(m, Event)]


def step(core: WorldCore, now_ns: int, verdict: bool = True) -> WorldState:
    out = core.begin_tick(now_ns)
    prop = next(m for _, m in out if isinstance(m, Proposed))
    v = (
        Verdict(tick=prop.tick, revision=prop.revision, ids=prop.ids, collided=[False] * len(prop.ids))
        if verdict
        else None
    )
    done = core.finish_tick(v)
    return next(m for _, m in done if isinstance(m, WorldState))
