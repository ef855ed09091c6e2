"""The world's logic: the clock, the motor model and kinematics, the only writer of poses.

Each tick: apply the latest actions (those that arrived during the previous tick), propose next
poses, wait for the collision verdict, commit, publish the state. Real time (default) ticks every
period whoever is late; lock-step waits for every live agent's actions (or a timeout naming the
laggards) and runs as fast as they answer. A robot whose actions are stale has its motors
zeroed; one whose agent is gone is zeroed at once and removed after a grace period; while no
collision process answers, every robot is held still.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import msgspec
import numpy as np

from iw_zenoh import keys
from iw_zenoh.convert import grid_to_msg, lab_to_msg, spec_from_msg, spec_to_msg
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.collision import Collisions
from iw_zenoh.core.lab import Grid, Lab, Scene, Wall, check_wall
from iw_zenoh.core.modes import Mode, Profile
from iw_zenoh.core.motor import MAX_POWER
from iw_zenoh.core.noise import Stream, rng_for, standard_normals
from iw_zenoh.core.spec import RobotType
from iw_zenoh.core.world import Proposal, WorldState, commit, initial_state, propose
from iw_zenoh.errors import SpecError
from iw_zenoh.messages import (
    Actions,
    AgentLostData,
    CollisionData,
    Control,
    EventData,
    EventKind,
    Hit,
    Obstacle,
    ObstacleData,
    Outgoing,
    PoseReport,
    Proposed,
    RefusedData,
    RegisteredData,
    RegisterReply,
    RegisterRequest,
    RobotSpecMsg,
    Tick,
    Verdict,
    WorldInfo,
    make_event,
)
from iw_zenoh.messages import (
    WorldState as WorldStateMsg,
)
from iw_zenoh.nodes.registry import Refused, Registry

__all__ = ["WorldConfig", "WorldCore"]

MS = 1_000_000


@dataclass(frozen=True)
class WorldConfig:
    """How the world runs.

    Attributes:
        sim: Simulation name.
        period_ms: Tick period (simulated time per tick; real time too in real-time mode).
        mode: ``realtime`` or ``lockstep``.
        profile: ``native`` or ``ciberrato``.
        seed: Seeds movement noise.
        action_timeout_ms: Actions older than this (wall clock) zero the motors.
        grace_ms: A robot whose agent is gone is removed after this.
        lockstep_timeout_ms: Lock-step waits this long for a tick's actions before going on.
        verdict_timeout_ms: Longest wait for a collision verdict (lock-step); real time waits
            at most half a period.
        expect: Robots to wait for before the first tick (a scenario's roster).
        duration_ticks: Stop after this many ticks (0: run until stopped).
        start_paused: Do not tick until a ``start`` control arrives.
        motors_noise_pct: Ciber-Rato MotorsNoise (legacy profile).
    """

    sim: str = "default"
    period_ms: float = 100.0
    mode: Mode = Mode.REALTIME
    profile: Profile = Profile.NATIVE
    seed: int = 0
    action_timeout_ms: float = 500.0
    grace_ms: float = 5000.0
    lockstep_timeout_ms: float = 2000.0
    verdict_timeout_ms: float = 2000.0
    expect: int = 0
    duration_ticks: int = 0
    start_paused: bool = False
    motors_noise_pct: float = 0.0

    @property
    def period_ns(self) -> int:
        """The period in ns."""
        return int(round(self.period_ms * MS))


class WorldCore:
    """The world's logic, without I/O: inputs are decoded messages, outputs ``(key, message)``.

    Args:
        cfg: How to run.
        lab: The map.
        grid: Start positions.
    """

    def __init__(self, cfg: WorldConfig, lab: Lab, grid: Grid) -> None:
        self.cfg = cfg
        self.base_lab = lab
        self.obstacles: dict[str, Obstacle] = {}
        self.scene = Scene(lab)
        self.registry = Registry(self.scene, grid)
        self.grid = grid
        self.revision = 0
        self.state = initial_state(np.zeros((0, 3)))
        self.bodies = Bodies.from_specs([])
        self.running = not cfg.start_paused
        self.steps_left = 0
        self.stopped = False
        self.collision_alive: set[str] = set()
        self.sensors_alive: set[str] = set()
        self.agents_alive: set[str] = set()
        self.holding = ""
        self._motion_rngs: dict[int, np.random.Generator] = {}
        # lock-step: the robots tick n still waits for, kept up to date as actions arrive (the
        # loop asks after every input; scanning the roster each time is quadratic at 1,000 robots)
        self._awaiting: tuple[int, set[int]] | None = None
        self._pending: tuple[int, Proposal] | None = None
        self._ids: list[int] = []
        self._stale = False  # the roster changed since the arrays were built
        self._new_poses: dict[int, np.ndarray] = {}  # start poses of robots not yet in the arrays
        self._robot_msgs: tuple[int, list[RobotSpecMsg]] = (-1, [])  # info's robots, by revision
        self._tick_wall_ns = 0
        self._answered: dict[tuple[str, str], RegisterReply] = {}
        self.collisions = 0

    # --- small helpers ---------------------------------------------------------------------

    @property
    def tick(self) -> int:
        """Ticks stepped so far."""
        return self.state.tick

    def sim_time_ns(self, tick: int | None = None) -> int:
        """Simulated time at ``tick`` (default now)."""
        return (self.tick if tick is None else tick) * self.cfg.period_ns

    def _event(
        self, kind: EventKind, reason: str, robot_id: int = -1, key: str = "", payload: EventData | None = None
    ) -> Outgoing:
        return keys.event(self.cfg.sim, kind), make_event(
            kind,
            payload,
            reason=reason,
            tick=self.tick,
            sim_time_ns=self.sim_time_ns(),
            robot_id=robot_id,
            key=key,
            source="world",
        )

    def _rebuild(self, keep_pose: dict[int, np.ndarray]) -> None:
        """Notes that the roster changed; the arrays are rebuilt once, when the next tick begins
        (a thousand robots registering one by one rebuilt them a thousand times: minutes)."""
        self._awaiting = None
        self._new_poses.update(keep_pose)
        self._stale = True
        self.revision += 1

    def _build(self) -> None:
        """Rebuilds the arrays for the current roster, keeping every surviving robot's state."""
        if not self._stale:
            return
        self._stale = False
        keep_pose, self._new_poses = self._new_poses, {}
        old = {rid: i for i, rid in enumerate(self._ids)}
        ids = self.registry.ids
        n = len(ids)
        pose = np.zeros((n, 3))
        out = np.zeros((n, 2))
        col = np.zeros(n, dtype=bool)
        for i, rid in enumerate(ids):
            if rid in old:
                j = old[rid]
                pose[i] = self.state.pose[j]
                out[i] = self.state.motor_out[j]
                col[i] = self.state.collided[j]
            else:
                pose[i] = keep_pose[rid]
        self._ids = ids
        self.state = WorldState(self.state.tick, pose, out, np.zeros((n, 2)), col, np.zeros((n, 2)))
        self.bodies = Bodies.from_specs(self.registry.specs())

    def poses_by_id(self) -> dict[int, tuple[float, float, float]]:
        """Current pose of every registered robot by id (newcomers at their start pose)."""
        entries = self.registry.entries
        out = {
            rid: (float(p[0]), float(p[1]), float(p[2]))
            for rid, p in zip(self._ids, self.state.pose, strict=True)
            if rid in entries
        }
        for rid, p in self._new_poses.items():
            if rid in entries:
                out[rid] = (float(p[0]), float(p[1]), float(p[2]))
        return out

    # --- inputs ----------------------------------------------------------------------------

    def register(self, req: RegisterRequest, now_ns: int) -> tuple[RegisterReply, list[Outgoing]]:
        """Accepts or refuses a registration (a request asked again gets its first answer)."""
        if req.request_id:
            seen = self._answered.get((req.agent, req.request_id))
            if seen is not None:
                return seen, []
        reply, out = self._register(req, now_ns)
        if req.request_id:
            self._answered[(req.agent, req.request_id)] = reply
        return reply, out

    def _register(self, req: RegisterRequest, now_ns: int) -> tuple[RegisterReply, list[Outgoing]]:
        try:
            spec = spec_from_msg(req.spec)
        except SpecError as e:
            return self._refuse(req, f"field {e.field}: {e.reason}")
        try:
            placed = self.registry.place(spec, self.poses_by_id())
        except Refused as e:
            return self._refuse(req, str(e))
        entry = self.registry.add(placed, req.agent, now_ns)
        # lock-step: its first readings are of the next tick, so it owes nothing for this one;
        # and its agent is alive (an agent declares its token before it registers), whether or
        # not the token has reached us yet: waiting for it from the first tick keeps a run the
        # same every time
        entry.last_action_tick = self.tick
        if req.agent:
            self.agents_alive.add(req.agent)
            self._awaiting = None
        pose = np.array([placed.x_m or 0.0, placed.y_m or 0.0, np.radians(placed.dir_deg or 0.0)])
        self._rebuild({placed.id: pose})
        msg = spec_to_msg(placed)
        reply = RegisterReply(tick=self.tick, sim_time_ns=self.sim_time_ns(), ok=True, robot_id=placed.id, spec=msg)
        out: list[Outgoing] = [
            (keys.spec(self.cfg.sim, placed.id), reply),
            self._event(
                EventKind.REGISTERED,
                f"robot {placed.id} {placed.name!r} at ({placed.x_m:g}, {placed.y_m:g})",
                placed.id,
                payload=RegisteredData(agent=req.agent),
            ),
        ]
        return reply, out

    def _refuse(self, req: RegisterRequest, reason: str) -> tuple[RegisterReply, list[Outgoing]]:
        reply = RegisterReply(tick=self.tick, sim_time_ns=self.sim_time_ns(), ok=False, reason=reason)
        return reply, [
            self._event(
                EventKind.REFUSED, reason, req.spec.id, payload=RefusedData(name=req.spec.name, agent=req.agent)
            )
        ]

    def on_actions(self, msg: Actions, now_ns: int) -> list[Outgoing]:
        """Takes a robot's actions (applied at the next tick)."""
        e = self.registry.entries.get(msg.robot_id)
        if e is None:
            return []
        e.cmd = (msg.left, msg.right)
        e.last_action_ns = now_ns
        if e.spec.type != RobotType.REAL:
            # a Real robot answers a tick with its pose report: its actions and its report are
            # two messages on two keys that may arrive in either order, and stepping on the
            # actions alone would use the pose of the tick before (differently each run)
            e.last_action_tick = max(e.last_action_tick, msg.tick)
            self._mark_answered(msg.robot_id, msg.tick)
        e.leds = {"end": msg.end_led, "returning": msg.returning_led, "visiting": msg.visiting_led}
        if e.watchdog:
            e.watchdog = False
            return [self._event(EventKind.WATCHDOG_CLEARED, f"robot {msg.robot_id} is commanded again", msg.robot_id)]
        return []

    def on_pose_report(self, msg: PoseReport, now_ns: int) -> None:
        """Takes a Real robot's own pose."""
        e = self.registry.entries.get(msg.robot_id)
        if e is None or e.spec.type != RobotType.REAL:
            return
        e.report = (msg.x, msg.y, float(np.radians(msg.dir_deg)))
        e.last_action_ns = now_ns
        e.last_action_tick = max(e.last_action_tick, msg.tick)
        self._mark_answered(msg.robot_id, msg.tick)

    def _mark_answered(self, robot_id: int, tick: int) -> None:
        if self._awaiting is not None and tick >= self._awaiting[0]:
            self._awaiting[1].discard(robot_id)

    def remove(self, robot_id: int, reason: str) -> list[Outgoing]:
        """Removes a robot from the world."""
        if self.registry.remove(robot_id) is None:
            return []
        self._motion_rngs.pop(robot_id, None)
        self._rebuild({})
        return [self._event(EventKind.REMOVED, reason, robot_id)]

    def on_control(self, msg: Control) -> list[Outgoing]:
        """Start, pause, step, stop, remove a robot, add / move / remove an obstacle."""
        c = msg.command
        if c == "start":
            self.running, self.steps_left = True, 0
            return [self._event(EventKind.STARTED, "simulation running")]
        if c == "pause":
            self.running = False
            return [self._event(EventKind.PAUSED, "simulation paused")]
        if c == "step":
            self.running = False
            self.steps_left += msg.steps
            return []
        if c == "stop":
            self.stopped = True
            return [self._event(EventKind.STOPPED, "stop requested")]
        if c == "remove":
            return self.remove(msg.robot_id, f"robot {msg.robot_id} removed by control")
        if c == "seek":
            return [self._event(EventKind.BAD_CONTROL, "seek is for replays; a live world cannot go back in time")]
        return self._obstacle(msg)

    def _obstacle(self, msg: Control) -> list[Outgoing]:
        ob = msg.obstacle
        if ob is None:
            return [
                self._event(EventKind.BAD_CONTROL, f"{msg.command} needs an obstacle", key=keys.control(self.cfg.sim))
            ]
        if msg.command == "remove_obstacle":
            if self.obstacles.pop(ob.name, None) is None:
                return [self._event(EventKind.BAD_CONTROL, f"no obstacle named {ob.name!r}")]
        else:
            x0, x1 = sorted((ob.x0, ob.x1))
            y0, y1 = sorted((ob.y0, ob.y1))
            corners = ((x0, y0), (x1, y0), (x1, y1), (x0, y1))
            why = check_wall(corners, self.base_lab.width_m, self.base_lab.height_m)
            if why:
                return [self._event(EventKind.BAD_CONTROL, f"obstacle {ob.name!r}: {why}")]
            if msg.command == "move_obstacle" and ob.name not in self.obstacles:
                return [self._event(EventKind.BAD_CONTROL, f"no obstacle named {ob.name!r} to move")]
            self.obstacles[ob.name] = msgspec.structs.replace(ob, x0=x0, y0=y0, x1=x1, y1=y1)
        walls = tuple(
            Wall(((o.x0, o.y0), (o.x1, o.y0), (o.x1, o.y1), (o.x0, o.y1)), o.height) for o in self.obstacles.values()
        )
        self.scene = Scene(self.base_lab.with_walls(walls))
        self.registry.scene = self.scene
        self.revision += 1
        return [self._event(EventKind.OBSTACLE, f"{msg.command} {ob.name!r}", payload=ObstacleData(name=ob.name))]

    def on_alive(self, role: str, name: str, alive: bool, now_ns: int) -> list[Outgoing]:
        """Tracks collision and sensors processes and agents; an agent lost zeroes its robots at once."""
        self._awaiting = None
        out: list[Outgoing] = []
        if role == "collision":
            was = bool(self.collision_alive)
            (self.collision_alive.add if alive else self.collision_alive.discard)(name)
            if was and not self.collision_alive and self.cfg.mode == Mode.LOCKSTEP:
                self.holding = "no collision process is alive: lock-step waits until one is back"
                out.append(self._event(EventKind.HOLDING, f"every robot held still: {self.holding}"))
        elif role == "sensors":
            was = bool(self.sensors_alive)
            (self.sensors_alive.add if alive else self.sensors_alive.discard)(name)
            if was and not self.sensors_alive and self.cfg.mode == Mode.LOCKSTEP:
                out.append(
                    self._event(
                        EventKind.SENSORS_LOST, "no sensors process is alive: lock-step waits until one is back"
                    )
                )
        elif role == "agent":
            if alive:
                self.agents_alive.add(name)
                for e in self.registry.entries.values():
                    if e.agent == name:
                        e.lost_ns = None
            else:
                self.agents_alive.discard(name)
                for rid, e in self.registry.entries.items():
                    if e.agent == name and e.lost_ns is None:
                        e.lost_ns = now_ns
                        e.cmd = (0.0, 0.0)
                        out.append(
                            self._event(
                                EventKind.AGENT_LOST,
                                f"agent {name!r} is gone: robot {rid} stopped",
                                rid,
                                payload=AgentLostData(agent=name),
                            )
                        )
        return out

    def _motion_rng(self, rid: int) -> np.random.Generator:
        g = self._motion_rngs.get(rid)
        if g is None:  # built once per robot
            g = self._motion_rngs[rid] = rng_for(self.cfg.seed, rid, Stream.MOTION)
        return g

    # --- the tick --------------------------------------------------------------------------

    def due(self) -> bool:
        """Whether the world should step now (running, or single steps asked, roster complete, and
        in lock-step a collision and a sensors process alive: a tick stepped without verdicts
        would hold every robot, and one without readings could not be answered; either would
        make a run depend on when those processes joined)."""
        if self.stopped or len(self.registry.entries) < self.cfg.expect and self.tick == 0:
            return False
        if (
            self.cfg.mode == Mode.LOCKSTEP
            and self.registry.entries
            and not (self.sensors_alive and self.collision_alive)
        ):
            return False
        return self.running or self.steps_left > 0

    def expected(self, tick: int) -> list[int]:
        """Robots whose actions for sensors tick ``tick`` lock-step still waits for."""
        return [
            rid
            for rid, e in self.registry.entries.items()
            if e.agent and e.agent in self.agents_alive and e.lost_ns is None and e.last_action_tick < tick
        ]

    def waiting(self, tick: int) -> bool:
        """Whether lock-step still waits for some robot's actions for sensors tick ``tick``."""
        if self._awaiting is None or self._awaiting[0] != tick:
            self._awaiting = (tick, set(self.expected(tick)))
        return bool(self._awaiting[1])

    def begin_tick(self, now_ns: int, wall_ns: int = 0) -> list[Outgoing]:
        """Applies commands and watchdogs, proposes next poses; returns the proposal to publish."""
        out: list[Outgoing] = []
        timeout_ns = int(self.cfg.action_timeout_ms * MS)
        lockstep = self.cfg.mode == Mode.LOCKSTEP
        for rid, e in list(self.registry.entries.items()):
            if e.lost_ns is not None and now_ns - e.lost_ns > self.cfg.grace_ms * MS:
                out += self.remove(
                    rid, f"robot {rid} removed: its agent {e.agent!r} has been gone {self.cfg.grace_ms:g} ms"
                )
        self._build()
        ids = self._ids
        cmd = np.zeros((len(ids), 2))
        report = np.full((len(ids), 3), np.nan)
        for i, rid in enumerate(ids):
            e = self.registry.entries[rid]
            # lock-step: a robot that answered the last tick is on time however long the
            # others took (a wall-clock watchdog there zeroed a door that had answered while a
            # chair planned, differently each run)
            answered = lockstep and e.last_action_tick >= self.tick
            stale = now_ns - e.last_action_ns > timeout_ns and not answered
            if stale and not e.watchdog and e.lost_ns is None and e.spec.type != RobotType.REAL:
                e.watchdog = True
                why = f"robot {rid}: no actions for {self.cfg.action_timeout_ms:g} ms, motors zeroed"
                out.append(self._event(EventKind.WATCHDOG, why, rid))
            if not (e.watchdog or e.lost_ns is not None):
                cmd[i] = e.cmd
            if e.report is not None:
                report[i] = e.report
        self.state = replace(self.state, cmd=cmd)
        profile = Profile(self.cfg.profile)
        z = None
        if len(ids) and (
            profile == Profile.CIBERRATO
            and self.cfg.motors_noise_pct > 0
            or bool(np.any(self.bodies.noise_std["motion"] > 0))
        ):
            rngs = [self._motion_rng(rid) for rid in ids]
            z = standard_normals(rngs, 2)
        prop = propose(
            self.state,
            self.bodies,
            dt_s=self.cfg.period_ms / 1000.0,
            profile=profile,
            noise_z=z,
            motors_noise_pct=self.cfg.motors_noise_pct,
            reported_pose=report,
        )
        n = self.tick + 1
        self._pending = (n, prop)
        self._tick_wall_ns = wall_ns
        s = self.state.pose
        msg = Proposed(
            tick=n,
            sim_time_ns=self.sim_time_ns(n),
            revision=self.revision,
            ids=list(ids),
            x=s[:, 0].tolist(),
            y=s[:, 1].tolist(),
            heading=s[:, 2].tolist(),
            next_x=prop.pose[:, 0].tolist(),
            next_y=prop.pose[:, 1].tolist(),
            next_heading=prop.pose[:, 2].tolist(),
            linear=prop.linear.tolist(),
            active=[True] * len(ids),
            rolled_left=prop.rolled_m[:, 0].tolist(),
            rolled_right=prop.rolled_m[:, 1].tolist(),
            tick_wall_ns=wall_ns,
        )
        out.append((keys.proposed(self.cfg.sim), msg))
        return out

    def verdict_ok(self, v: Verdict) -> bool:
        """Whether a verdict answers the pending proposal."""
        return (
            self._pending is not None
            and v.tick == self._pending[0]
            and v.revision == self.revision
            and v.ids == self._ids
        )

    def finish_tick(self, verdict: Verdict | None) -> list[Outgoing]:
        """Commits the proposal given the verdict (or holds everyone without one)."""
        assert self._pending is not None
        n, prop = self._pending
        self._pending = None
        ids = list(self._ids)
        out: list[Outgoing] = []
        hold: np.ndarray | None = None
        if verdict is None:
            reason = "no collision process is alive" if not self.collision_alive else "the collision verdict is late"
            hold = np.ones(len(ids), dtype=bool)
            if ids and self.holding != reason:  # an empty world holds nobody (a world starting first)
                out.append(self._event(EventKind.HOLDING, f"every robot held still: {reason}"))
                self.holding = reason
            col = Collisions.none(len(ids))
        else:
            if self.holding:
                out.append(self._event(EventKind.RESUMED, "collision verdicts are back; robots move again"))
            self.holding = ""
            c = np.asarray(verdict.collided, dtype=bool)
            col = Collisions(c, c.copy(), c.copy(), np.zeros((0, 2), dtype=np.int64), np.zeros((0, 2), dtype=np.int64))
        was = self.state.collided.copy()
        self.state = commit(self.state, prop, col, profile=Profile(self.cfg.profile), hold=hold)
        self.state = replace(self.state, tick=n)
        if verdict is not None:
            by_robot: dict[int, list[Hit]] = {}
            for h in verdict.hits:
                by_robot.setdefault(h.robot_id, []).append(h)
            for i, rid in enumerate(ids):
                if self.state.collided[i] and not was[i]:
                    self.collisions += 1
                    what = ", ".join(
                        f"wall {h.wall}" if h.wall >= 0 else f"robot {h.other}" for h in by_robot.get(rid, [])
                    )
                    x, y = self.state.pose[i, :2]
                    walls = [h.wall for h in by_robot.get(rid, []) if h.wall >= 0]
                    robots = [h.other for h in by_robot.get(rid, []) if h.other >= 0]
                    reason = f"robot {rid} hit {what or 'something'} at ({x:.2f}, {y:.2f})"
                    hit = CollisionData(x=float(x), y=float(y), walls=walls, robots=robots)
                    out.append(self._event(EventKind.COLLISION, reason, rid, payload=hit))
        if self.steps_left > 0:
            self.steps_left -= 1
        s = self.state
        moved = ~s.collided if hold is None else np.zeros(len(ids), dtype=bool)
        if Profile(self.cfg.profile) == Profile.NATIVE:
            speed = np.where(moved, prop.linear / MAX_POWER * self.bodies.drive.max_speed_mps, 0.0)
        else:
            speed = np.where(moved, prop.linear / (self.cfg.period_ms / 1000.0), 0.0)
        msg = WorldStateMsg(
            tick=n,
            sim_time_ns=self.sim_time_ns(n),
            revision=self.revision,
            ids=ids,
            x=s.pose[:, 0].tolist(),
            y=s.pose[:, 1].tolist(),
            heading=s.pose[:, 2].tolist(),
            collided=s.collided.tolist(),
            rolled_left=s.rolled_m[:, 0].tolist(),
            rolled_right=s.rolled_m[:, 1].tolist(),
            speed=np.asarray(speed, dtype=float).tolist(),
            held=hold is not None,
            held_reason=self.holding,
            tick_wall_ns=self._tick_wall_ns,
        )
        out.append((keys.state(self.cfg.sim), msg))
        out.append((keys.tick(self.cfg.sim), self.tick_msg()))
        if self.cfg.duration_ticks and n >= self.cfg.duration_ticks:
            self.stopped = True
            out.append(self._event(EventKind.STOPPED, f"duration reached: {n} ticks"))
        return out

    def tick_msg(self) -> Tick:
        """The clock message for the current tick."""
        return Tick(
            tick=self.tick,
            sim_time_ns=self.sim_time_ns(),
            period_ns=self.cfg.period_ns,
            mode=Mode(self.cfg.mode),
            running=self.running,
            revision=self.revision,
        )

    def _robots_msg(self) -> list[RobotSpecMsg]:
        """Every robot's spec as sent in info (built once per revision)."""
        if self._robot_msgs[0] != self.revision:
            self._robot_msgs = (self.revision, [spec_to_msg(s) for s in self.registry.specs()])
        return self._robot_msgs[1]

    def info(self) -> WorldInfo:
        """Everything a late joiner needs."""
        lab = self.scene.lab
        return WorldInfo(
            tick=self.tick,
            sim_time_ns=self.sim_time_ns(),
            revision=self.revision,
            lab=lab_to_msg(lab),
            grid=grid_to_msg(self.grid),
            profile=Profile(self.cfg.profile),
            mode=Mode(self.cfg.mode),
            period_ns=self.cfg.period_ns,
            seed=self.cfg.seed,
            robots=self._robots_msg(),
            obstacles=list(self.obstacles.values()),
            sim=self.cfg.sim,
        )
