"""What the viewer's page is told: the world's batched messages turned into page messages
(:mod:`iw_zenoh.messages.page`), sending only what changed where that is cheap.

Free of I/O: the server hands each decoded message in with the wall time it arrived, and sends
what comes back to every page. A page that joins (or falls behind) gets :meth:`Feed.snapshot`.
"""

from __future__ import annotations

import collections
import itertools
from dataclasses import dataclass
from typing import Any

import msgspec
import numpy as np

from iw_zenoh.convert import spec_from_msg
from iw_zenoh.core.geometry import circle_outline, rect_outline
from iw_zenoh.errors import IwError
from iw_zenoh.messages import (
    CollisionData,
    Event,
    EventKind,
    RadioBatch,
    RobotSpecMsg,
    SensorBatch,
    SensorReading,
    Tick,
    WorldInfo,
    WorldState,
    event_payload,
)
from iw_zenoh.messages.page import (
    PageCommand,
    PageEvent,
    PageFrame,
    PageHeard,
    PageLaser,
    PageMessage,
    PageReading,
    PageReadings,
    PageRobot,
    PageScans,
    PageScene,
    PageSensor,
    PageStatus,
    PageWall,
)

__all__ = ["Feed", "ScansWanted"]

EVENTS_KEPT = 20  # a robot's recent events shown in its panel
RTF_WINDOW_NS = 2_000_000_000  # the real-time factor is measured over the last 2 s of wall time
STATUS_EVERY_NS = 500_000_000  # the clock is re-sent at least this often while ticks come
PROX_STEP_M = 0.01  # a reading that moved less than this is not sent again
POSE_DIGITS = 4  # poses rounded to 0.1 mm / 0.1 mrad on the page: shorter JSON, nothing visible lost


def _robot(m: RobotSpecMsg, agent: str) -> PageRobot:
    """A robot as the page draws it (outline, cones and scanners in its own frame)."""
    try:
        s = spec_from_msg(m)
    except (IwError, ValueError):  # the world accepted it: draw the box it says
        return PageRobot(
            id=m.id, name=m.name, type=m.type, outline=[], sensors=[], spec=msgspec.to_builtins(m), agent=agent
        )
    if m.shape == "circle":
        pts = circle_outline(np.array([0.5 * s.width_m]))[0]
    else:
        pts = rect_outline(np.array([s.width_m]), np.array([s.height_m]), np.array([s.com]))[0]
    sensors = [
        PageSensor(id=i.id, x=i.x_m, y=i.y_m, angle_deg=i.angle_deg, cone_deg=i.cone_deg, range_m=i.range_m)
        for i in s.sensors
    ]
    lasers = [
        PageLaser(id=a.id, x=a.x_m, y=a.y_m, angle_deg=a.angle_deg, fov_deg=a.fov_deg, beams=a.beams, range_m=a.range_m)
        for a in s.lasers
    ]
    return PageRobot(
        id=m.id,
        name=m.name,
        type=m.type,
        outline=[(round(float(x), 4), round(float(y), 4)) for x, y in pts],
        sensors=sensors,
        spec=msgspec.to_builtins(m),
        agent=agent,
        lasers=lasers,
    )


def _prox(values: list[float | None]) -> list[float | None]:
    return [None if v is None else round(v, 2) for v in values]


def _scans(r: SensorReading, order: list[int]) -> list[list[float | None]]:
    """A reading's laser ranges, one list per scanner in ``order`` (empty: not in the reading)."""
    by_id = {a.id: a.ranges for a in r.lasers} if isinstance(r.lasers, list) else {}
    return [_prox(by_id.get(i, [])) for i in order]


@dataclass(frozen=True)
class ScansWanted:
    """Which robots' laser scans one page draws, so only those are sent to it.

    Attributes:
        every: Every robot's (the scans toggle on; what a page gets until it says).
        robot_id: Otherwise only this robot's (the selected one; ``None``: no robot's).
    """

    every: bool = True
    robot_id: int | None = None

    @classmethod
    def of(cls, cmd: PageCommand) -> ScansWanted:
        """What a page's ``scans`` command asks for."""
        if cmd.scans == "all":
            return cls()
        return cls(every=False, robot_id=cmd.robot_id if cmd.scans == "selected" else None)

    def keep(self, msg: PageScans) -> PageScans | None:
        """The part of ``msg`` this page draws (``None``: nothing of it)."""
        if self.every:
            return msg
        key = str(self.robot_id)
        if self.robot_id is None or key not in msg.scans:
            return None
        return PageScans(tick=msg.tick, scans={key: msg.scans[key]})


class Feed:
    """The page's view of one simulation.

    Args:
        sim: The simulation name.
    """

    def __init__(self, sim: str) -> None:
        self.sim = sim
        self.info: WorldInfo | None = None
        self.scene: PageScene | None = None
        self.state: WorldState | None = None
        self.ids: list[int] = []
        self.tick: Tick | None = None
        self.readings: dict[int, SensorReading] = {}
        self.agents: dict[int, str] = {}
        self.watchdog: set[int] = set()
        self.events: dict[int, collections.deque[dict[str, Any]]] = {}
        self._sensor_ids: dict[int, list[int]] = {}
        self._sent_prox: dict[int, list[float | None]] = {}
        self._laser_ids: dict[int, list[int]] = {}  # robots with scanners: their scanners' ids, as drawn
        self._sent_scans: dict[int, list[list[float | None]]] = {}
        self._clock: collections.deque[tuple[int, int]] = collections.deque()  # (wall ns, sim ns) of states
        self._status_sent: tuple[int, PageStatus] | None = None

    # --- what the world says -------------------------------------------------------------------

    def on_info(self, info: WorldInfo) -> list[PageMessage]:
        """A description of the world: a new scene when its revision is not the one shown (older
        too: a replay sought back, a world started afresh)."""
        if self.info is not None and info.revision == self.info.revision and info.lab == self.info.lab:
            return []
        self.info = info
        lab = info.lab
        own = len(lab.walls) - len(info.obstacles)  # the obstacles are the lab's last walls
        if isinstance(info.agents, list):  # the world says who drives each robot (older ones did not)
            self.agents.update((r.id, a) for r, a in zip(info.robots, info.agents, strict=True))
        robots = [_robot(r, self.agents.get(r.id, "")) for r in info.robots]
        self._sensor_ids = {r.id: [s.id for s in r.sensors] for r in robots}
        self._laser_ids = {r.id: [a.id for a in r.lasers] for r in robots if r.lasers}
        self.scene = PageScene(
            revision=info.revision,
            name=lab.name,
            width=lab.width,
            height=lab.height,
            walls=[PageWall(corners=list(w.corners), height=w.height) for w in lab.walls[: max(own, 0)]],
            obstacles=list(info.obstacles),
            beacons=list(lab.beacons),
            targets=list(lab.targets),
            robots=robots,
            period_ns=info.period_ns,
        )
        self._sent_prox = {rid: v for rid, v in self._sent_prox.items() if rid in self._sensor_ids}
        self._sent_scans = {rid: v for rid, v in self._sent_scans.items() if rid in self._laser_ids}
        return [self.scene]

    def needs_info(self, revision: int) -> bool:
        """Whether a message of ``revision`` names another world than the scene shown."""
        return self.info is None or revision != self.info.revision

    def on_tick(self, tick: Tick, wall_ns: int) -> list[PageMessage]:
        """The clock: a status when mode or running changed, or now and then while it runs."""
        self.tick = tick
        status = self._status(wall_ns)
        last = self._status_sent
        if last is not None and (
            (last[1].running, last[1].mode) == (status.running, status.mode) and wall_ns - last[0] < STATUS_EVERY_NS
        ):
            return []
        self._status_sent = (wall_ns, status)
        return [status]

    def _status(self, wall_ns: int) -> PageStatus:
        t = self.tick
        rtf = 0.0
        if len(self._clock) > 1 and t is not None and t.running:
            (w0, s0), (w1, s1) = self._clock[0], self._clock[-1]
            rtf = (s1 - s0) / (w1 - w0) if w1 > w0 else 0.0
        return PageStatus(
            tick=t.tick if t is not None else 0,
            t_ns=t.sim_time_ns if t is not None else 0,
            mode=str(t.mode) if t is not None else "",
            running=bool(t.running) if t is not None else False,
            rtf=round(rtf, 3),
            period_ns=t.period_ns if t is not None else 0,
        )

    def on_state(self, st: WorldState, wall_ns: int, sent_ms: float = 0.0) -> list[PageMessage]:
        """A tick's committed state: one frame (its ids only when the roster changed)."""
        self.state = st
        self._clock.append((wall_ns, st.sim_time_ns))
        while len(self._clock) > 2 and wall_ns - self._clock[0][0] > RTF_WINDOW_NS:
            self._clock.popleft()
        roster_changed = st.ids != self.ids
        if roster_changed:
            self.ids = list(st.ids)
            self.watchdog &= set(self.ids)
        return [self._frame(with_ids=roster_changed, sent_ms=sent_ms)]

    def _frame(self, *, with_ids: bool, sent_ms: float = 0.0) -> PageFrame:
        st = self.state
        assert st is not None
        if st.held:
            state = "h" * len(st.ids)
        else:
            wd = self.watchdog
            state = "".join("c" if c else "w" if rid in wd else "d" for rid, c in zip(st.ids, st.collided, strict=True))
        return PageFrame(
            tick=st.tick,
            t_ns=st.sim_time_ns,
            ids=list(st.ids) if with_ids else None,
            x=[round(v, POSE_DIGITS) for v in st.x],
            y=[round(v, POSE_DIGITS) for v in st.y],
            heading=[round(v, POSE_DIGITS) for v in st.heading],
            state=state,
            held_reason=st.held_reason,
            sent_ms=sent_ms,
            tick_wall_ms=st.tick_wall_ns / 1e6,
        )

    def on_sensors(self, batch: SensorBatch) -> list[PageMessage]:
        """A shard's readings: the proximity readings that moved since last sent."""
        return self.on_readings(batch.tick, batch.readings)

    def on_readings(self, tick: int, readings: list[SensorReading]) -> list[PageMessage]:
        """Readings (a batch's, or one robot's from a recording without batches): the proximity
        readings and laser scans that moved since last sent."""
        changed: dict[str, list[float | None]] = {}
        scans: dict[str, list[list[float | None]]] = {}
        for r in readings:
            self.readings[r.robot_id] = r
            lasers = self._laser_ids.get(r.robot_id)
            if lasers is not None:
                got = _scans(r, lasers)
                old = self._sent_scans.get(r.robot_id)
                if old is None or self._moved(list(itertools.chain(*old)), list(itertools.chain(*got))):
                    self._sent_scans[r.robot_id] = got
                    scans[str(r.robot_id)] = got
            order = self._sensor_ids.get(r.robot_id)
            if order is None:
                continue
            if order == r.proximity_ids:
                values = _prox(r.proximity_m)
            else:
                by_id = dict(zip(r.proximity_ids, r.proximity_m, strict=True))
                values = _prox([by_id.get(i) for i in order])
            if self._moved(self._sent_prox.get(r.robot_id), values):
                self._sent_prox[r.robot_id] = values
                changed[str(r.robot_id)] = values
        out: list[PageMessage] = [PageReadings(tick=tick, prox=changed)] if changed else []
        return out + [PageScans(tick=tick, scans=scans)] if scans else out

    @staticmethod
    def _moved(old: list[float | None] | None, new: list[float | None]) -> bool:
        if old is None or len(old) != len(new):
            return True
        for a, b in zip(old, new, strict=True):
            if (a is None) != (b is None) or (a is not None and b is not None and abs(a - b) >= PROX_STEP_M):
                return True
        return False

    def on_radio(self, batch: RadioBatch) -> list[PageMessage]:
        """What the radio delivered this tick."""
        heard = [(h.robot_id, m.sender, round(m.distance_m, 2), m.text) for h in batch.hear for m in h.messages]
        return [PageHeard(tick=batch.tick, messages=heard)] if heard else []

    def on_event(self, ev: Event) -> list[PageMessage]:
        """An event: remembered for its robot's panel, kept for the watchdog colour, and shown."""
        rid = ev.robot_id
        where: tuple[float, float] | None = None
        if ev.kind == EventKind.COLLISION:
            try:
                c = event_payload(ev, CollisionData)
                where = (c.x, c.y)
            except (IwError, TypeError):
                where = None
        if where is None and rid >= 0:
            where = self.pose_of(rid)
        if ev.kind == EventKind.WATCHDOG:
            self.watchdog.add(rid)
        elif ev.kind in (EventKind.WATCHDOG_CLEARED, EventKind.REMOVED):
            self.watchdog.discard(rid)
        if ev.kind == EventKind.REGISTERED:
            self.agents[rid] = str(ev.data.get("agent", ""))
        if ev.kind == EventKind.REMOVED:
            self._forget(rid)
        elif rid >= 0:
            kept = self.events.setdefault(rid, collections.deque(maxlen=EVENTS_KEPT))
            kept.append({"tick": ev.tick, "t_ns": ev.sim_time_ns, "kind": str(ev.kind), "reason": ev.reason})
        return [
            PageEvent(tick=ev.tick, t_ns=ev.sim_time_ns, kind=str(ev.kind), reason=ev.reason, robot_id=rid, where=where)
        ]

    def _forget(self, rid: int) -> None:
        """What was kept of a robot goes with it (a viewer runs for hours while robots come and go)."""
        self.readings.pop(rid, None)
        self.agents.pop(rid, None)
        self.events.pop(rid, None)
        self._sent_prox.pop(rid, None)
        self._sent_scans.pop(rid, None)

    # --- what a page asks ----------------------------------------------------------------------

    def pose_of(self, robot_id: int) -> tuple[float, float] | None:
        """Where a robot is now (``None``: not in the last state)."""
        st = self.state
        if st is None or robot_id not in st.ids:
            return None
        i = st.ids.index(robot_id)
        return st.x[i], st.y[i]

    def reading(self, robot_id: int) -> PageReading:
        """Everything known of one robot now: its reading, speed, motor powers, pose, recent events."""
        st = self.state
        r = self.readings.get(robot_id)
        speed = motors = pose = None
        if st is not None and robot_id in st.ids:
            i = st.ids.index(robot_id)
            speed, motors, pose = (
                st.speed[i],
                (st.rolled_left[i], st.rolled_right[i]),
                (st.x[i], st.y[i], st.heading[i]),
            )
        reading = msgspec.to_builtins(r) if r is not None else None
        if reading is not None:
            reading["agent"] = self.agents.get(robot_id, "")
        return PageReading(
            robot_id=robot_id,
            reading=reading,
            speed=speed,
            motors=motors,
            pose=pose,
            events=list(self.events.get(robot_id, ())),
        )

    def snapshot(self, wall_ns: int) -> list[PageMessage]:
        """What a page that joins now needs: the scene, the clock, the last frame with its ids,
        every proximity reading and every laser scan."""
        out: list[PageMessage] = []
        if self.scene is not None:
            out.append(self.scene)
        if self.tick is not None:
            out.append(self._status(wall_ns))
        if self.state is not None:
            out.append(self._frame(with_ids=True))
        if self._sent_prox:
            out.append(
                PageReadings(
                    tick=self.state.tick if self.state else 0, prox={str(k): v for k, v in self._sent_prox.items()}
                )
            )
        scans = self.scans_now()
        return out + [scans] if scans is not None else out

    def scans_now(self) -> PageScans | None:
        """Every scanner's last scan sent (what a page that asks for more scans lacks); ``None``: none yet."""
        if not self._sent_scans:
            return None
        tick = self.state.tick if self.state else 0
        return PageScans(tick=tick, scans={str(k): v for k, v in self._sent_scans.items()})
