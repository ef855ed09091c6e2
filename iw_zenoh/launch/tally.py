"""What ``iwz run`` sees of a run (ticks, positions, events, who is alive), its verdict on the
criteria, and the world's last committed state (what a restarted world resumes from)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from iw_zenoh.errors import DecodeError
from iw_zenoh.messages import Event, EventKind, RegisteredData, WorldInfo, WorldState, event_payload
from iw_zenoh.scenario.tables import Criteria, DoorCriterion, Reach
from iw_zenoh.sim.doorwatch import DoorWatch
from iw_zenoh.sim.resume import WorldSnapshot, snapshot

__all__ = ["Tally"]


@dataclass
class Tally:
    """What the launcher saw of the run.

    Attributes:
        positions: Where each robot of the last state is, and where each robot the criteria name
            was last seen (bounded by what the world holds, not by how many robots came and went).
        reached: When each robot the criteria name first reached its goal (it counts after it left).
        owners: The agent of every robot registered and not removed (``registered`` events).
        agents_alive: Agent processes whose liveliness token is there.
        running: False while the world is paused.
        state: The last committed state heard.
        info: The world's latest description heard.
    """

    tick: int = 0
    sim_s: float = 0.0
    robots: int = 0
    collisions: int = 0
    positions: dict[int, tuple[float, float]] = field(default_factory=dict)
    reached: dict[int, float] = field(default_factory=dict)
    events: dict[str, int] = field(default_factory=dict)
    holding: str = ""
    agents_alive: set[str] = field(default_factory=set)
    owners: dict[int, str] = field(default_factory=dict)
    running: bool = True
    state: WorldState | None = None
    info: WorldInfo | None = None
    doors: DoorWatch = field(default_factory=DoorWatch)

    def on_event(self, ev: Event) -> None:
        """Counts an event; a collision, a hold and its end, who drives each robot, a pause are also kept."""
        self.events[str(ev.kind)] = self.events.get(str(ev.kind), 0) + 1
        if ev.kind == EventKind.REGISTERED:
            try:
                self.owners[ev.robot_id] = event_payload(ev, RegisteredData).agent
            except DecodeError:
                self.owners[ev.robot_id] = ""
        if ev.kind == EventKind.REMOVED:
            self.owners.pop(ev.robot_id, None)
        if ev.kind in (EventKind.PAUSED, EventKind.STARTED):
            self.running = ev.kind == EventKind.STARTED
        if ev.kind == EventKind.COLLISION:
            self.collisions += 1
        if ev.kind == EventKind.HOLDING:
            self.holding = ev.reason
        if ev.kind == EventKind.RESUMED:
            self.holding = ""

    def on_state(self, st: WorldState, reach: tuple[Reach, ...], doors: tuple[DoorCriterion, ...] = ()) -> None:
        """Keeps the tick, the time and the position of every robot of the state (and the last one
        of a robot named by ``reach`` that left); notes each goal when first reached and what the
        doors of ``doors`` did."""
        self.tick, self.sim_s, self.robots = st.tick, st.sim_time_ns / 1e9, len(st.ids)
        self.state = st
        # the robots of this state, and the last place of those the criteria name that have left
        # (a verdict says where): a robot that left and nobody judges is forgotten
        kept = {r.robot: self.positions[r.robot] for r in reach if r.robot in self.positions}
        self.positions = kept | {rid: (x, y) for rid, x, y in zip(st.ids, st.x, st.y, strict=True)}
        if doors:
            poses = {rid: (x, y, h) for rid, x, y, h in zip(st.ids, st.x, st.y, st.heading, strict=True)}
            door_ids = {r.id for r in self.info.robots if r.type == "Door"} if self.info is not None else set()
            self.doors.observe(doors, self.sim_s, poses, door_ids)
        for r in reach:
            p = self.positions.get(r.robot)
            if p is not None and r.robot not in self.reached and math.hypot(p[0] - r.x_m, p[1] - r.y_m) <= r.within_m:
                self.reached[r.robot] = self.sim_s

    def robots_alive(self) -> int:
        """Robots in the last state whose agent is alive (or that have none): a robot whose agent
        is stopped or gone is not counted, though the world keeps it for its grace period."""
        if self.state is None:
            return 0
        return sum(
            1 for rid in self.state.ids if self.owners.get(rid, "") in self.agents_alive or not self.owners.get(rid)
        )

    def status(self, wall_s: float, agents_alive: int, agents: int) -> str:
        """The live status line: what is really alive, an agent whose token is there (a stopped
        one is not, though its process exists), a robot whose agent is (the world keeps a lost one
        for its grace period) out of the robots the world holds."""
        rtf = self.sim_s / wall_s if wall_s > 0 else 0.0
        line = (
            f"t={self.sim_s:7.1f} s  tick {self.tick:6d}  RTF {rtf:5.2f}x  robots {self.robots_alive()}/{self.robots}  "
            f"collisions {self.collisions}  agents {agents_alive}/{agents}"
        )
        return line + (f"  HOLDING: {self.holding}" if self.holding else "")

    def snapshot(self) -> WorldSnapshot | None:
        """The world's last committed state, for a world restarted in its place (None: the world's
        description was never heard, so there is nothing to resume)."""
        if self.info is None:
            return None
        return snapshot(self.state, self.info, self.owners, running=self.running)

    def verdict(self, crit: Criteria) -> tuple[bool, list[str]]:
        """Whether the criteria are met, and a line per criterion."""
        lines: list[str] = []
        ok = True
        if crit.max_collisions is not None:
            good = self.collisions <= crit.max_collisions
            ok &= good
            lines.append(f"{'PASS' if good else 'FAIL'} collisions {self.collisions} (at most {crit.max_collisions})")
        for r in crit.reach:
            when = self.reached.get(r.robot)
            good = when is not None
            ok &= good
            at = self.positions.get(r.robot)
            where = f"last at ({at[0]:.2f}, {at[1]:.2f})" if at else "never seen"
            lines.append(
                f"{'PASS' if good else 'FAIL'} robot {r.robot} within {r.within_m:g} m of ({r.x_m:g}, {r.y_m:g})"
                + (f" at t={when:.1f} s" if good else f": {where}")
            )
        good, door_lines = self.doors.verdict(crit.doors)
        return ok and good, lines + door_lines
