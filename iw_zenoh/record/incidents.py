"""``iwz incidents FILE [--json]``: the moments worth looking at in a recording.

Collisions, near misses (two bodies, or a body and a wall, closer than a threshold without
touching), watchdog stops, agents or processes lost, robots held for want of a collision
process, refused registrations, dropped radio messages, malformed messages and laggards; each
with its simulation time, robots and positions, in time order.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import IO

import numpy as np
import shapely

from iw_zenoh.convert import lab_from_msg, spec_from_msg
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.lab import Scene
from iw_zenoh.core.spec import RobotType
from iw_zenoh.errors import DecodeError, IwError
from iw_zenoh.messages import CollisionData, Event, EventKind, WorldInfo, WorldState, event_payload
from iw_zenoh.record.reader import RecordingReader, file_error, open_recording, print_notes

__all__ = ["Incident", "clearance_arg", "find_incidents", "main"]

EVENT_KINDS = {
    EventKind.COLLISION: "collision",
    EventKind.WATCHDOG: "watchdog stop",
    EventKind.AGENT_LOST: "agent lost",
    EventKind.HOLDING: "robots held (no collision verdict)",
    EventKind.REFUSED: "registration refused",
    EventKind.RADIO_DROPPED: "radio messages dropped",
    EventKind.BAD_MESSAGE: "malformed message",
    EventKind.LAGGARD: "lock-step laggard",
    EventKind.REMOVED: "robot removed",
}


@dataclass
class Incident:
    """One moment to look at."""

    t: float  # simulation time, s
    kind: str
    what: str
    robots: list[int] = field(default_factory=list)
    where: list[tuple[float, float]] = field(default_factory=list)


HYSTERESIS = 1.5  # a near miss ends only when the gap grows past 1.5 x the threshold


def _close_pairs(scene: Scene, polys: np.ndarray, ids: list[int], dist: float) -> set[tuple[int, int]]:
    """(robot, robot) and (robot, -1 - wall) pairs closer than ``dist``."""
    pairs: set[tuple[int, int]] = set()
    a, b = shapely.STRtree(polys).query(polys, predicate="dwithin", distance=dist)
    for i, j in zip(a, b, strict=True):
        if i < j:
            pairs.add((ids[i], ids[j]))
    if len(scene.wall_polygons):
        ri, wi = scene.wall_tree.query(polys, predicate="dwithin", distance=dist)
        for i, w in zip(ri, wi, strict=True):
            pairs.add((ids[i], -1 - int(w)))
    return pairs


class _Finder:
    """Follows a recording message by message and notes its incidents."""

    def __init__(self, near_m: float) -> None:
        self.near_m = near_m
        self.out: list[Incident] = []
        self.view: tuple[Scene, dict[int, object]] | None = None
        self.near_now: set[tuple[int, int]] = set()
        self.last_pos: dict[int, tuple[float, float]] = {}
        self.cache: dict[tuple[int, ...], Bodies] = {}

    def on_info(self, info: WorldInfo) -> None:
        self.view = (Scene(lab_from_msg(info.lab)), {s.id: spec_from_msg(s) for s in info.robots})
        self.cache = {}

    def on_event(self, ev: Event) -> None:
        label = EVENT_KINDS.get(ev.kind)
        if label is None:
            return
        who = [ev.robot_id] if ev.robot_id >= 0 else []
        at = [self.last_pos[ev.robot_id]] if ev.robot_id in self.last_pos else []
        if ev.kind == EventKind.COLLISION:
            try:
                hit = event_payload(ev, CollisionData)
                at = [(hit.x, hit.y)]
            except DecodeError:
                pass  # where the robot last was, then
        self.out.append(Incident(ev.sim_time_ns / 1e9, str(ev.kind), f"{label}: {ev.reason}", who, at))

    def on_state(self, st: WorldState) -> None:
        if self.view is None:
            return
        for rid, x, y in zip(st.ids, st.x, st.y, strict=True):
            self.last_pos[rid] = (x, y)
        scene, specs = self.view
        ids = [i for i in st.ids if i in specs]
        if not ids:
            return
        idx = [st.ids.index(i) for i in ids]
        pose = np.column_stack([np.asarray(st.x)[idx], np.asarray(st.y)[idx], np.asarray(st.heading)[idx]])
        key = tuple(ids)
        bodies = self.cache.get(key)
        if bodies is None:
            bodies = self.cache[key] = Bodies.from_specs([specs[i] for i in ids])  # type: ignore[misc]
        polys = shapely.polygons(bodies.world_outline(pose))
        collided = {ids[k] for k in range(len(ids)) if st.collided[idx[k]]}
        pairs = _close_pairs(scene, polys, ids, self.near_m)
        still = _close_pairs(scene, polys, ids, self.near_m * HYSTERESIS)  # an episode ends past this
        doors = {i for i in ids if getattr(specs[i], "type", None) == RobotType.DOOR}
        for a_id, b_id in sorted(pairs - self.near_now):
            if a_id in collided or (b_id >= 0 and b_id in collided):
                continue
            if a_id in doors and (b_id < 0 or b_id in doors):
                continue  # doors hang in walls and a revolving door's leaves share a hub: no incident
            i = ids.index(a_id)
            if b_id >= 0:
                j = ids.index(b_id)
                gap = float(shapely.distance(polys[i], polys[j]))
                what = f"near miss: robots {a_id} and {b_id} {gap:.2f} m apart"
                members, spots = [a_id, b_id], [pose[i, :2], pose[j, :2]]
            else:
                gap = float(shapely.distance(polys[i], scene.wall_polygons[-1 - b_id]))
                what = f"near miss: robot {a_id} {gap:.2f} m from wall {-1 - b_id}"
                members, spots = [a_id], [pose[i, :2]]
            places = [(float(q[0]), float(q[1])) for q in spots]
            self.out.append(Incident(st.sim_time_ns / 1e9, "near-miss", what, members, places))
        self.near_now = (self.near_now & still) | pairs


def find_incidents(f: IO[bytes] | RecordingReader, *, near_m: float = 0.2) -> list[Incident]:
    """Every incident in a recording, in time order.

    Args:
        f: The recording (a stream, or a reader over one).
        near_m: Clearance under which two bodies (or a body and a wall) count as a near miss.

    Raises:
        RecordingError: When the recording cannot be read.
    """
    rec = f if isinstance(f, RecordingReader) else RecordingReader(f)
    finder = _Finder(near_m)
    for r in rec.records(("info", "event", "state")):
        match r.message:
            case WorldInfo() as info:
                finder.on_info(info)
            case Event() as ev:
                finder.on_event(ev)
            case WorldState() as st:
                finder.on_state(st)
    finder.out.sort(key=lambda i: i.t)
    return finder.out


def clearance_arg(text: str) -> float:
    """An argparse type: the near-miss clearance, a positive finite number of metres."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"a clearance is a positive number of metres, e.g. 0.3; got {text!r}")
    return v


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz incidents``."""
    p = argparse.ArgumentParser(
        prog="iwz incidents",
        description="List the incidents of a recording: collisions, near misses, stops, losses, refusals, drops.",
    )
    p.add_argument("file", help="MCAP recording")
    p.add_argument("--near", type=clearance_arg, default=0.2, help="near-miss clearance, m (default 0.2)")
    p.add_argument("--json", action="store_true", help="one JSON array")
    args = p.parse_args(argv)
    try:
        with open_recording(args.file) as rec:
            found = find_incidents(rec, near_m=args.near)
            print_notes("iwz incidents", rec)
    except IwError as e:  # not MCAP, cut off, damaged
        print(f"iwz incidents: {file_error(args.file, e)}; check it with iwz doctor (and iwz recover)")
        return 2
    if args.json:
        print(json.dumps([asdict(i) for i in found]))
        return 0
    for i in found:
        where = " ".join(f"({x:.2f}, {y:.2f})" for x, y in i.where)
        print(f"t={i.t:8.2f} s  {i.kind:<14} {i.what}  {where}")
    print(f"{len(found)} incidents")
    return 0
