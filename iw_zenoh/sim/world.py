"""The world's logic: the clock, the motor model and kinematics, the only writer of poses.

Each tick: apply the latest actions (those that arrived during the previous tick), propose next
poses, wait for the collision verdict, commit, publish the state. Real time (default) ticks every
period whoever is late; lock-step waits for every live agent's actions (or a timeout naming the
laggards) and runs as fast as they answer. A robot whose actions are stale has its motors
zeroed (in the ciberrato profile, or with ``silence`` keep, it keeps its last command, as the
legacy simulator's motors do); one whose agent is gone is zeroed at once and removed after a grace period; while no
collision process answers, every robot is held still.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from cachetools import LRUCache

from iw_zenoh import keys
from iw_zenoh.convert import grid_to_msg, lab_to_msg, spec_to_msg
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.lab import Grid, Lab, Scene
from iw_zenoh.core.modes import Mode, Profile, Silence
from iw_zenoh.core.spec import RobotSpec, RobotType
from iw_zenoh.core.world import Proposal, commit_flags, committed, initial_state, propose, with_cmd
from iw_zenoh.core.world import WorldState as CoreState
from iw_zenoh.messages import (
    Actions,
    Control,
    EventData,
    EventKind,
    LabMsg,
    ObstacleData,
    Outgoing,
    PoseReport,
    RegisterReply,
    RegisterRequest,
    RobotSpecMsg,
    Tick,
    Verdict,
    WorldInfo,
    make_event,
)
from iw_zenoh.sim.admission import admit
from iw_zenoh.sim.batches import collision_reports, proposed_msg, speeds, state_msg
from iw_zenoh.sim.config import MS, WorldConfig
from iw_zenoh.sim.motion import MotionNoise
from iw_zenoh.sim.obstacles import Obstacles
from iw_zenoh.sim.presence import Presence
from iw_zenoh.sim.registry import Registry

__all__ = ["ANSWERS_KEPT", "WorldCore"]

# registrations whose answer is kept for a request asked again (an agent's retry comes within its
# timeout, seconds later): far more than can be in flight at once, so the table never grows with
# the run's length, only up to this
ANSWERS_KEPT = 4096


class WorldCore:
    """The world's logic, without I/O: inputs are decoded messages, outputs ``(key, message)``.

    Args:
        cfg: How to run.
        lab: The map.
        grid: Start positions.
    """

    def __init__(self, cfg: WorldConfig, lab: Lab, grid: Grid) -> None:
        self.cfg = cfg
        self.obstacles = Obstacles(lab)
        self.scene = Scene(lab)
        self.registry = Registry(self.scene, grid)
        self.grid = grid
        self.revision = 0
        self.state = initial_state(np.zeros((0, 3)))
        self.bodies = Bodies.from_specs([])
        self.running = not cfg.start_paused
        self.steps_left = 0
        self.stopped = False
        self._last_tick_ns: int | None = None  # when the last tick began (None: not yet)
        self._paused = cfg.start_paused  # a pause's length is not silence (see begin_tick)
        self.presence = Presence(self.registry, lockstep=cfg.mode == Mode.LOCKSTEP, event=self.event)
        # the same sets, by the names the wiring and the tests use
        self.collision_alive = self.presence.collision
        self.sensors_alive = self.presence.sensors
        self.agents_alive = self.presence.agents
        self.motion = MotionNoise(cfg.seed)
        self._pending: tuple[int, Proposal] | None = None
        self._robot_msgs: tuple[int, list[RobotSpecMsg]] = (-1, [])  # info's robots, by revision
        self._spec_msgs: dict[int, tuple[RobotSpec, RobotSpecMsg]] = {}  # each robot's, while its spec stays
        self._lab_msg: tuple[Lab, LabMsg] | None = None  # info's lab, while the lab stays
        self._tick_wall_ns = 0
        self._answered: LRUCache[tuple[str, str], RegisterReply] = LRUCache(ANSWERS_KEPT)
        self.collisions = 0
        # what every tick uses, worked out once (the configuration does not change)
        self._profile = Profile(cfg.profile)
        self._period_ns = cfg.period_ns
        self._dt_s = cfg.period_ms / 1000.0
        self._watchdog_ns = int(cfg.action_timeout_ms * MS) if cfg.silent_robots == Silence.STOP else None
        self._proposed_key, self._state_key, self._tick_key = (
            keys.proposed(cfg.sim),
            keys.state(cfg.sim),
            keys.tick(cfg.sim),
        )
        self._noisy: tuple[Bodies, bool] | None = None  # whether some body's motion is noisy, per roster

    # --- small helpers ---------------------------------------------------------------------

    @property
    def tick(self) -> int:
        """Ticks stepped so far."""
        return self.state.tick

    def sim_time_ns(self, tick: int | None = None) -> int:
        """Simulated time at ``tick`` (default now)."""
        return (self.tick if tick is None else tick) * self._period_ns

    def event(
        self, kind: EventKind, reason: str, robot_id: int = -1, key: str = "", payload: EventData | None = None
    ) -> Outgoing:
        """An event of the world's, stamped with the current tick, to publish."""
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

    def roster_changed(self) -> None:
        """A robot registered or left: a new revision (the arrays follow when the next tick begins)."""
        self.presence.forget()
        self.revision += 1

    def _build(self) -> None:
        """Rebuilds the arrays when the roster changed, keeping every surviving robot's state."""
        built = self.registry.arrange(self.state)
        if built is not None:
            self.state, self.bodies = built

    # --- inputs ----------------------------------------------------------------------------

    def register(self, req: RegisterRequest, now_ns: int) -> tuple[RegisterReply, list[Outgoing]]:
        """Accepts or refuses a registration (a request asked again gets its first answer)."""
        if req.request_id:
            seen = self._answered.get((req.agent, req.request_id))
            if seen is not None:
                return seen, []
        reply, out = admit(self, req, now_ns)
        if req.request_id:
            self._answered[(req.agent, req.request_id)] = reply
        return reply, out

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
            self.presence.answered(msg.robot_id, msg.tick)
        e.leds = {"end": msg.end_led, "returning": msg.returning_led, "visiting": msg.visiting_led}
        if e.watchdog:
            e.watchdog = False
            return [self.event(EventKind.WATCHDOG_CLEARED, f"robot {msg.robot_id} is commanded again", msg.robot_id)]
        return []

    def on_pose_report(self, msg: PoseReport, now_ns: int) -> None:
        """Takes a Real robot's own pose."""
        e = self.registry.entries.get(msg.robot_id)
        if e is None or e.spec.type != RobotType.REAL:
            return
        e.report = (msg.x, msg.y, float(np.radians(msg.dir_deg)))
        e.last_action_ns = now_ns
        e.last_action_tick = max(e.last_action_tick, msg.tick)
        self.presence.answered(msg.robot_id, msg.tick)

    def remove(self, robot_id: int, reason: str) -> list[Outgoing]:
        """Removes a robot from the world."""
        if self.registry.remove(robot_id) is None:
            return []
        self.motion.forget(robot_id)
        self.roster_changed()
        return [self.event(EventKind.REMOVED, reason, robot_id)]

    def move(self, robot_id: int, x_m: float, y_m: float, dir_deg: float) -> None:
        """Puts a robot at rest at a new pose from the next tick: motors, command and collision
        flag cleared, its id, spec and noise streams kept, so the roster (and every array built
        for it) does not change (a learning environment's restart; no message asks for it).

        Raises:
            KeyError: No such robot.
            Refused: The place is outside the lab, on a wall or on another robot.
        """
        e = self.registry.entries[robot_id]
        self._build()
        others = self.registry.poses_near(self.state, x_m, y_m)
        others.pop(robot_id, None)
        placed = e.spec.placed(robot_id, x_m, y_m, dir_deg)
        self.registry.check_free(placed, others, shape=self.registry.shape(robot_id))
        st, i = self.state, self.registry.arrayed.index(robot_id)
        pose, out, cmd, hit, rolled = (
            st.pose.copy(),
            st.motor_out.copy(),
            st.cmd.copy(),
            st.collided.copy(),
            st.rolled_m.copy(),
        )
        pose[i] = (x_m, y_m, math.radians(dir_deg))
        out[i], cmd[i], hit[i], rolled[i] = 0.0, 0.0, False, 0.0
        self.state = CoreState(st.tick, pose, out, cmd, hit, rolled)  # copies: earlier ticks' arrays are the caller's
        e.cmd = (0.0, 0.0)

    def on_control(self, msg: Control) -> list[Outgoing]:
        """Start, pause, step, stop, remove a robot, add / move / remove an obstacle."""
        c = msg.command
        if c == "start":
            self.running, self.steps_left = True, 0
            return [self.event(EventKind.STARTED, "simulation running")]
        if c == "pause":
            self.running, self._paused = False, True
            return [self.event(EventKind.PAUSED, "simulation paused")]
        if c == "step":
            self.running, self._paused = False, True
            self.steps_left += msg.steps
            return []
        if c == "stop":
            self.stopped = True
            return [self.event(EventKind.STOPPED, "stop requested")]
        if c == "remove":
            if msg.robot_id not in self.registry.entries:  # say so: an operator waits for an answer
                return [self.event(EventKind.BAD_CONTROL, f"no robot {msg.robot_id} to remove", msg.robot_id)]
            return self.remove(msg.robot_id, f"robot {msg.robot_id} removed by control")
        if c == "seek":
            return [self.event(EventKind.BAD_CONTROL, "seek is for replays; a live world cannot go back in time")]
        if c in ("estop", "clear"):
            return []  # for the chair's serial bridge, not the world
        return self._obstacle(msg)

    def _obstacle(self, msg: Control) -> list[Outgoing]:
        ob = msg.obstacle
        if ob is None:
            return [
                self.event(EventKind.BAD_CONTROL, f"{msg.command} needs an obstacle", key=keys.control(self.cfg.sim))
            ]
        why = self.obstacles.apply(msg.command, ob)
        if why:
            return [self.event(EventKind.BAD_CONTROL, why)]
        self.scene = Scene(self.obstacles.lab())
        self.registry.scene = self.scene
        self.revision += 1
        return [self.event(EventKind.OBSTACLE, f"{msg.command} {ob.name!r}", payload=ObstacleData(name=ob.name))]

    def on_alive(self, role: str, name: str, alive: bool, now_ns: int) -> list[Outgoing]:
        """Tracks collision and sensors processes and agents; an agent lost zeroes its robots at once."""
        return self.presence.on_alive(role, name, alive, now_ns)

    def overdue(self, now_ns: int) -> list[Outgoing]:
        """Agents whose liveliness never appeared within the grace period after they registered
        are lost (:meth:`Presence.overdue`). The world's loop asks once a pass (a paused world's
        too); :meth:`begin_tick` removes their robots once the grace after that is over."""
        return self.presence.overdue(now_ns, int(self.cfg.grace_ms * MS))

    # --- the tick --------------------------------------------------------------------------

    def due(self) -> bool:
        """Whether the world should step now (running, or single steps asked, roster complete, and
        the processes a tick needs alive: :meth:`Presence.complete`)."""
        if self.stopped or len(self.registry.entries) < self.cfg.expect and self.tick == 0:
            return False
        if not self.presence.complete(first=self.tick == 0 and self._profile == Profile.CIBERRATO):
            return False
        return self.running or self.steps_left > 0

    @property
    def starts_on_the_cycle(self) -> bool:
        """Whether a paused world that may step (start, step, its roster complete) waits for its
        next cycle rather than stepping at once: in the ciberrato profile, as the legacy
        simulator starts at its next timer tick, so an action sent just before Start is applied
        at tick 1 and never overtaken by it."""
        return self._profile == Profile.CIBERRATO

    def expected(self, tick: int) -> list[int]:
        """Robots whose actions for sensors tick ``tick`` lock-step still waits for."""
        return self.presence.expected(tick)

    def waiting(self, tick: int) -> bool:
        """Whether lock-step still waits for some robot's actions for sensors tick ``tick``."""
        return self.presence.waiting(tick)

    def waiting_for(self, tick: int) -> int:
        """How many robots' actions for sensors tick ``tick`` lock-step still waits for."""
        return self.presence.waiting_for(tick)

    def begin_tick(self, now_ns: int, wall_ns: int = 0) -> list[Outgoing]:
        """Applies commands and watchdogs, proposes next poses; returns the proposal to publish."""
        out: list[Outgoing] = []
        if self._paused:
            # agents hear nothing while the world is paused, so the pause is not their silence
            self.registry.excuse_pause(now_ns, last_tick_ns=self._last_tick_ns)
            self._paused = False
        self._last_tick_ns = now_ns
        grace_ns = self.cfg.grace_ms * MS
        gone = [
            (rid, e.agent)
            for rid, e in self.registry.entries.items()
            if e.lost_ns is not None and now_ns - e.lost_ns > grace_ns
        ]
        for rid, agent in gone:
            out += self.remove(rid, f"robot {rid} removed: its agent {agent!r} has been gone {self.cfg.grace_ms:g} ms")
        ids = self.arrays()
        cmd, report, fired = self.registry.commands(
            ids,
            now_ns=now_ns,
            timeout_ns=self._watchdog_ns,
            answered_tick=self.tick if self.presence.lockstep else None,
        )
        if fired:
            silent = f"no actions for {self.cfg.action_timeout_ms:g} ms, motors zeroed"
            out += [self.event(EventKind.WATCHDOG, f"robot {rid}: {silent}", rid) for rid in fired]
        prop = self.propose_next(cmd, report)
        n = self.tick + 1
        self._tick_wall_ns = wall_ns
        msg = proposed_msg(
            self.state, prop, ids, sim_time_ns=self.sim_time_ns(n), revision=self.revision, wall_ns=wall_ns
        )
        out.append((self._proposed_key, msg))
        return out

    def arrays(self) -> list[int]:
        """The robots' ids in array order, the arrays rebuilt first if the roster changed."""
        self._build()
        return self.registry.arrayed

    def propose_next(self, cmd: np.ndarray, report: np.ndarray | None = None) -> Proposal:
        """Tick n's proposal from (N, 2) wheel powers in array order (and (N, 3) poses Real robots
        reported, NaN rows for none), pending until :meth:`commit_next`: what :meth:`begin_tick` does
        once it has the commands, without a message (:class:`~iw_zenoh.sim.local.LocalWorld`'s
        array path calls it directly)."""
        self.state = with_cmd(self.state, cmd)
        profile = self._profile
        prop = propose(
            self.state,
            self.bodies,
            dt_s=self._dt_s,
            profile=profile,
            noise_z=self._motion_noise(self.registry.arrayed, profile),
            motors_noise_pct=self.cfg.motors_noise_pct,
            reported_pose=report,
        )
        self._pending = (self.state.tick + 1, prop)
        return prop

    def took(
        self, cmd: np.ndarray, pose: np.ndarray, motor_out: np.ndarray, rolled_m: np.ndarray, collided: np.ndarray
    ) -> tuple[int, np.ndarray]:
        """Makes tick n the state a caller proposed, checked and committed in one call, from the
        (N, 2) powers it applied (:mod:`iw_zenoh.core.fused`, LocalWorld's fused tick): what
        :meth:`propose_next` then :meth:`commit_next` with its flags leave, nobody held.

        Returns:
            The tick, and the collision flags before it.
        """
        was = self.state.collided
        self.state = committed(self.state.tick + 1, pose, motor_out, cmd, collided, rolled_m)
        self._pending = None
        if self.steps_left > 0:
            self.steps_left -= 1
        return self.state.tick, was

    def motion_normals(self) -> np.ndarray | None:
        """This tick's (N, 2) standard normals of movement noise, in array order (None when no
        robot's motion is noisy): drawn from each robot's stream, so ask once a tick."""
        return self._motion_noise(self.registry.arrayed, self._profile)

    def _motion_noise(self, ids: list[int], profile: Profile) -> np.ndarray | None:
        """This tick's standard normals of movement noise (None when no robot's motion is noisy)."""
        if len(ids) and (profile == Profile.CIBERRATO and self.cfg.motors_noise_pct > 0 or self._motion_noisy()):
            return self.motion.normals(ids)
        return None

    def _motion_noisy(self) -> bool:
        """Whether some robot's motion is noisy (worked out again only when the roster changes)."""
        if self._noisy is None or self._noisy[0] is not self.bodies:
            self._noisy = (self.bodies, bool(np.any(self.bodies.noise_std["motion"] > 0)))
        return self._noisy[1]

    def verdict_ok(self, v: Verdict) -> bool:
        """Whether a verdict answers the pending proposal."""
        return (
            self._pending is not None
            and v.tick == self._pending[0]
            and v.revision == self.revision
            and v.ids == self.registry.arrayed
        )

    def finish_tick(self, verdict: Verdict | None) -> list[Outgoing]:
        """Commits the proposal given the verdict (or holds everyone without one)."""
        ids = list(self.registry.arrayed)
        out = self.presence.on_verdict(verdict is not None, bool(ids))
        n, prop, hold, was = self.commit_next(None if verdict is None else np.asarray(verdict.collided, dtype=bool))
        if verdict is not None:
            for rid, reason, hit in collision_reports(verdict, ids, self.state.collided & ~was, self.state.pose):
                self.collisions += 1
                out.append(self.event(EventKind.COLLISION, reason, rid, payload=hit))
        msg = state_msg(
            self.state,
            ids,
            sim_time_ns=self.sim_time_ns(n),
            revision=self.revision,
            speed_mps=speeds(prop, profile=self._profile, bodies=self.bodies, period_ms=self.cfg.period_ms),
            held_reason=None if hold is None else self.presence.holding,
            tick_wall_ns=self._tick_wall_ns,
        )
        out.append((self._state_key, msg))
        out.append((self._tick_key, self.tick_msg()))
        if self.cfg.duration_ticks and n >= self.cfg.duration_ticks:
            self.stopped = True
            out.append(self.event(EventKind.STOPPED, f"duration reached: {n} ticks"))
        return out

    def commit_next(self, collided: np.ndarray | None) -> tuple[int, Proposal, np.ndarray | None, np.ndarray]:
        """Commits the pending proposal given (N,) collision flags (None: no verdict came, every
        robot is held): what :meth:`finish_tick` does before its messages.

        Returns:
            The tick, its proposal, the robots held (None: none) and the collision flags before.
        """
        assert self._pending is not None
        n, prop = self._pending
        self._pending = None
        hold: np.ndarray | None = None
        if collided is None:
            hold = np.ones(len(self.registry.arrayed), dtype=bool)
            collided = np.zeros(len(hold), dtype=bool)
        was = self.state.collided.copy()
        # the flags alone: a Collisions built around them (with copies) cost more than the commit
        self.state = commit_flags(self.state, prop, collided, profile=self._profile, hold=hold)
        if self.state.tick != n:  # commit counts the tick already
            self.state = replace(self.state, tick=n)
        if self.steps_left > 0:
            self.steps_left -= 1
        return n, prop, hold, was

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
            # a robot whose spec is the same object keeps its message: a robot coming or going
            # converts one spec, not the roster's (256 of them took 1.5 ms)
            was, now = self._spec_msgs, {}
            for s in self.registry.specs():
                old = was.get(s.id)
                now[s.id] = old if old is not None and old[0] is s else (s, spec_to_msg(s))
            self._spec_msgs = now
            self._robot_msgs = (self.revision, [m for _, m in now.values()])
        return self._robot_msgs[1]

    def _lab_to_msg(self) -> LabMsg:
        """The lab's wire shape, converted again only when the lab changes (an obstacle)."""
        lab = self.scene.lab
        if self._lab_msg is None or self._lab_msg[0] is not lab:
            self._lab_msg = (lab, lab_to_msg(lab))
        return self._lab_msg[1]

    def info(self) -> WorldInfo:
        """Everything a late joiner needs."""
        return WorldInfo(
            tick=self.tick,
            sim_time_ns=self.sim_time_ns(),
            revision=self.revision,
            lab=self._lab_to_msg(),
            grid=grid_to_msg(self.grid),
            profile=Profile(self.cfg.profile),
            mode=Mode(self.cfg.mode),
            period_ns=self.cfg.period_ns,
            seed=self.cfg.seed,
            robots=self._robots_msg(),
            obstacles=list(self.obstacles.by_name.values()),
            sim=self.cfg.sim,
            agents=[e.agent for e in self.registry.entries.values()],  # in the order of robots
        )
