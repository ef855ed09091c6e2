"""The whole tick in one process: world, collision check, sensors and radio, with no Zenoh.

:class:`LocalWorld` runs the same logic the distributed roles run (:class:`~iw_zenoh.sim.world.WorldCore`,
:class:`~iw_zenoh.sim.collision.CollisionNode`, :class:`~iw_zenoh.sim.sensors.SensorsNode`,
:class:`~iw_zenoh.sim.radio.RadioNode`) as one loop, in the order a lock-step ``iwz run`` runs
them. With the same lab, robots, seed and commands it gives the states and readings of a lock-step
run bit for bit: ``iwz resim`` re-runs recordings with it, and :mod:`iw_zenoh.learn` builds its
learning environments on it.

A step is one tick::

    world = LocalWorld(lab, grid, seed=7)
    rid = world.add(prototype_chair("me"))
    s = world.step({})                      # tick 1: nothing commanded yet; the first readings
    while not s.readings[rid].collision:
        s = world.step({rid: (0.1, 0.1)})   # wheel powers answering the last readings

Commands given to :meth:`LocalWorld.step` are the answers to the previous step's readings (as an
agent's actions of sensors tick n are applied by the world at tick n + 1); a robot given no command
keeps its last one (lock-step: every agent answers every tick). What a robot says with its
commands (its answer to the last readings) is heard, by every robot within range, in the readings
the same step returns, as the radio delivers what was said during tick n - 1 with state n.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from iw_zenoh.convert import lab_from_msg, spec_from_msg, spec_to_msg
from iw_zenoh.core import fused
from iw_zenoh.core.bodies import Bodies
from iw_zenoh.core.drive import floats
from iw_zenoh.core.lab import Grid, Lab, Scene
from iw_zenoh.core.modes import Mode, Profile
from iw_zenoh.core.sensors import Readings, read_all_readings
from iw_zenoh.core.spec import RobotSpec, RobotType
from iw_zenoh.core.world import drive_table
from iw_zenoh.errors import IwError
from iw_zenoh.messages import (
    Actions,
    Event,
    Hear,
    Heard,
    Outgoing,
    PoseReport,
    Proposed,
    RegisterRequest,
    RobotSpecMsg,
    Say,
    SensorReading,
    WorldState,
)
from iw_zenoh.sim.collision import CollisionNode
from iw_zenoh.sim.config import WorldConfig
from iw_zenoh.sim.radio import RadioConfig, RadioNode
from iw_zenoh.sim.registry import Entry, Refused
from iw_zenoh.sim.sensors import SensorsNode
from iw_zenoh.sim.view import WorldView
from iw_zenoh.sim.world import WorldCore

__all__ = ["ArrayStep", "LocalWorld", "Step", "WheelCommand"]

NO_WATCHDOG_MS = 1e12  # lock-step: a robot's command stands until its agent answers again


class WheelCommand(Protocol):
    """Anything with wheel powers (an agent's ``Command``, an ``Actions`` message)."""

    @property
    def left(self) -> float: ...  # noqa: D102

    @property
    def right(self) -> float: ...  # noqa: D102


@dataclass
class Step:
    """What one tick gave.

    Attributes:
        state: The committed state of the tick.
        readings: Each robot's sensor reading of the tick, by robot id (empty when not sensed).
        heard: What each robot heard over the radio with this tick's readings (said with its commands).
        events: The world's events of the tick (collisions, stopped...).
        published: Everything the world published committing the tick, ``(key, message)`` (what
            a recording of the world holds).
    """

    state: WorldState
    readings: dict[int, SensorReading] = field(default_factory=dict)
    heard: dict[int, list[Heard]] = field(default_factory=dict)
    events: list[Event] = field(default_factory=list)
    published: list[Outgoing] = field(default_factory=list)


@dataclass
class ArrayStep:
    """What one tick gave, as arrays (:meth:`LocalWorld.step_arrays`): robot ``i`` is ``ids[i]``.

    Attributes:
        tick: The tick.
        ids: The robots' ids in array order.
        bodies: Their bodies (sensor layouts: :class:`~iw_zenoh.core.bodies.Bodies`).
        pose: (N, 3) committed poses: x, y (m), heading (rad), as the state's.
        collided: (N,) the tick's collision flags.
        rolled_m: (N, 2) how far each wheel rolled (left, right).
        readings: Every sensor of every robot (:class:`~iw_zenoh.core.sensors.Readings`), None
            when not sensed; the values a :class:`~iw_zenoh.messages.SensorReading` carries.
    """

    tick: int
    ids: list[int]
    bodies: Bodies
    pose: np.ndarray
    collided: np.ndarray
    rolled_m: np.ndarray
    readings: Readings | None


class LocalWorld:
    """A lock-step world stepped by its caller (see the module doc).

    Args:
        lab: The map.
        grid: Start positions (robots with no start pose of their own take them, by id).
        seed: The run's seed: movement noise and each robot's sensor noise derive from it, as in
            ``iwz run --seed``.
        profile: ``native`` or ``ciberrato``.
        period_ms: Simulated time a tick.
        sim: The simulation's name (in the messages' keys).
        radio: Radio limits (default Ciber-Rato's).
        duration_ticks: Stop after this many ticks (0: never); :attr:`stopped` says so.
        motors_noise_pct: Ciber-Rato MotorsNoise (legacy profile).
        threads: The sensors' kernels on up to this many threads when there are many robots
            (the same readings: :class:`~iw_zenoh.sim.sensors.SensorsNode`).
    """

    def __init__(
        self,
        lab: Lab,
        grid: Grid | None = None,
        *,
        seed: int = 0,
        profile: Profile = Profile.NATIVE,
        period_ms: float = 100.0,
        sim: str = "local",
        radio: RadioConfig | None = None,
        duration_ticks: int = 0,
        motors_noise_pct: float = 0.0,
        threads: int = 1,
    ) -> None:
        self.cfg = WorldConfig(
            sim=sim,
            period_ms=period_ms,
            mode=Mode.LOCKSTEP,
            profile=Profile(profile),
            seed=seed,
            action_timeout_ms=NO_WATCHDOG_MS,
            duration_ticks=duration_ticks,
            motors_noise_pct=motors_noise_pct,
        )
        self.world = WorldCore(self.cfg, lab, grid if grid is not None else Grid())
        self.collide = CollisionNode()
        self.sensors = SensorsNode(sim, seed, threads=threads)
        self.radio = RadioNode(sim, radio)
        self._view: WorldView | None = None
        self._scene_src: Scene | None = None  # the world's scene the view's was built from
        # each robot's spec as the view has it, with the message it came from (kept while the world
        # sends the same message: a robot removed and another added under its id is converted again)
        self._specs: dict[int, tuple[RobotSpecMsg, RobotSpec]] = {}
        self.last: Step | None = None
        self._entries: tuple[int, list[Entry]] = (-1, [])  # step_arrays' robots, by revision
        #: step_arrays computes a usual tick (the native profile, every robot sensed on the
        #: caller's thread, no beacons) in one compiled call (:mod:`iw_zenoh.core.fused`: the
        #: same kernels, the same numbers); False: the kernels one by one, as the roles call them
        self.fused = True
        self._fixed: tuple[Bodies, Scene, tuple[object, ...]] | None = None  # the fused tick's arguments, per roster

    # --- the roster ------------------------------------------------------------------------

    def add(self, spec: RobotSpec | RobotSpecMsg) -> int:
        """Registers a robot, as its agent would; returns its id.

        Raises:
            IwError: The world refused it (its reason: no free place, an id taken...).
        """
        msg = spec if isinstance(spec, RobotSpecMsg) else spec_to_msg(spec)
        reply, _ = self.world.register(RegisterRequest(spec=msg), self.world.sim_time_ns())
        if not reply.ok:
            raise IwError(f"robot {msg.name!r} refused: {reply.reason}")
        return reply.robot_id

    def remove(self, robot_id: int, reason: str = "removed") -> None:
        """Takes a robot out of the world (from the next tick)."""
        self.world.remove(robot_id, reason)

    def move(self, robot_id: int, x_m: float, y_m: float, dir_deg: float) -> None:
        """Puts a robot at rest at a new pose from the next step, keeping its id, spec and noise
        streams: an episode's restart without a new robot (adding and removing one rebuilds every
        array and cache that is per roster: milliseconds with hundreds of robots).

        Raises:
            IwError: No such robot, or the place is outside the lab, on a wall or on another robot.
        """
        if robot_id not in self.world.registry.entries:
            raise IwError(f"no robot {robot_id} to move")
        try:
            self.world.move(robot_id, x_m, y_m, dir_deg)
        except Refused as e:
            raise IwError(f"robot {robot_id} not moved: {e}") from e

    @property
    def ids(self) -> list[int]:
        """The registered robots' ids."""
        return sorted(self.world.registry.entries)

    def spec(self, robot_id: int) -> RobotSpec:
        """A registered robot's accepted spec (its id and start pose filled in)."""
        return self.world.registry.entries[robot_id].spec

    @property
    def tick(self) -> int:
        """Ticks stepped so far."""
        return self.world.tick

    @property
    def stopped(self) -> bool:
        """Whether ``duration_ticks`` is reached."""
        return self.world.stopped

    @property
    def state(self) -> WorldState | None:
        """The last committed state (None before the first step)."""
        return None if self.last is None else self.last.state

    def view(self) -> WorldView:
        """The world as the other roles see it (rebuilt when the roster changes; the scene and
        each robot's spec are kept while they stay, so a robot coming or going costs little)."""
        if self._view is None or self._view.info.revision != self.world.revision:
            wi = self.world.info()
            was, src = self._view, self.world.scene  # the world makes a new scene when its lab changes
            scene = was.scene if was is not None and src is self._scene_src else Scene(lab_from_msg(wi.lab))
            self._scene_src = src
            was_specs = self._specs
            self._specs = {
                s.id: kept if (kept := was_specs.get(s.id)) is not None and kept[0] is s else (s, spec_from_msg(s))
                for s in wi.robots
            }
            self._view = WorldView(wi, scene, {rid: spec for rid, (_, spec) in self._specs.items()})
        return self._view

    # --- the tick --------------------------------------------------------------------------

    def step(
        self,
        commands: Mapping[int, WheelCommand | tuple[float, float]] | None = None,
        *,
        say: Mapping[int, str] | None = None,
        sense: bool = True,
    ) -> Step:
        """Applies the commands, moves, checks collisions, commits, and reads the sensors.

        Args:
            commands: Wheel powers by robot id, ``(left, right)`` or anything with ``left`` and
                ``right`` (an agent's ``Command``, an ``Actions``); clamped to +-0.15 by the
                motor model. A ``Command``'s ``say`` and ``pose`` (a door's, a real chair's) are
                taken as its agent's process sends them. Unknown ids are ignored, as the world
                ignores them.
            say: Radio messages by robot id, with the commands (heard in this step's ``heard``).
            sense: Compute the readings (False skips sensors and radio: only states).

        Returns:
            The tick's state, readings, what was heard, and events.
        """
        w = self.world
        now = w.sim_time_ns(w.tick + 1)
        said = dict(say or {})
        for rid, c in (commands or {}).items():
            if isinstance(c, tuple):
                c = Actions(tick=w.tick, sim_time_ns=now, robot_id=rid, left=c[0], right=c[1])
            if getattr(c, "say", None) is not None:  # an agent's Command: what it says, its pose
                said[rid] = c.say  # type: ignore[attr-defined]
            pose = getattr(c, "pose", None)
            if pose is not None:
                x, y, d = pose
                w.on_pose_report(PoseReport(tick=w.tick, sim_time_ns=now, robot_id=rid, x=x, y=y, dir_deg=d), now)
            if getattr(c, "actions", True):  # False: a pose alone, another agent commands it
                w.on_actions(Actions(tick=w.tick, sim_time_ns=now, robot_id=rid, left=c.left, right=c.right), now)
        for rid, text in said.items():
            self.radio.on_say(Say(tick=w.tick, sim_time_ns=now, robot_id=rid, text=text))
        view = self.view()
        prop = next(m for _, m in w.begin_tick(now) if isinstance(m, Proposed))
        done = w.finish_tick(self.collide.on_proposed(prop, view))
        state = next(m for _, m in done if isinstance(m, WorldState))
        step = Step(state, events=[m for _, m in done if isinstance(m, Event)], published=done)
        if sense:
            for _, m in self.sensors.on_state(state, view):
                if isinstance(m, SensorReading):
                    step.readings[m.robot_id] = m
            for _, m in self.radio.on_state(state):
                if isinstance(m, Hear):
                    step.heard[m.robot_id] = list(m.messages)
                elif isinstance(m, Event):
                    step.events.append(m)
        self.last = step
        return step

    def step_arrays(self, powers: np.ndarray, *, sense: bool = True) -> ArrayStep:
        """One tick as :meth:`step` runs it, on arrays: no message is built, so it is the fast
        path for learning (every robot commanded every tick, nothing said).

        The same world, collision check and sensors run (the same functions, the same noise
        streams), so a run of it gives the states and readings :meth:`step` gives, bit for bit
        (``tests/sim/test_local.py``); the two may be mixed.

        Args:
            powers: (N, 2) wheel powers (left, right) of every robot, in :meth:`array_ids` order.
            sense: Compute the readings.

        Raises:
            IwError: A Real robot is in the world (its pose comes from its reports: use :meth:`step`),
                or ``powers`` is not (N, 2).
        """
        w = self.world
        ids = w.arrays()
        cmd = np.array(powers, dtype=np.float64)
        if cmd.shape != (len(ids), 2):
            raise IwError(f"step_arrays takes ({len(ids)}, 2) wheel powers, one row a robot, got {cmd.shape}")
        if self._entries[0] != w.revision:  # the roster's entries, checked once a revision
            entries = [w.registry.entries[rid] for rid in ids]
            if any(e.spec.type == RobotType.REAL for e in entries):
                raise IwError("step_arrays cannot step a Real robot (its agent reports its pose): use step()")
            self._entries = (w.revision, entries)
        entries = self._entries[1]
        for e, (left, right) in zip(entries, cmd.tolist(), strict=True):
            e.cmd = (left, right)  # as on_actions keeps them: a later step() without a command keeps them
        view = self.view()
        if sense and self.fused and w.cfg.profile == Profile.NATIVE:
            inputs = self.sensors.fused_inputs(w.tick + 1, ids, w.bodies, view)
            if inputs is not None:
                return self._step_fused(cmd, ids, view, *inputs)
        before = w.state.pose
        prop = w.propose_next(cmd)
        col = self.collide.check(view, w.bodies, before, prop.pose, prop.linear)
        n, _, _, was = w.commit_next(col.collided)
        st = w.state
        w.collisions += int(np.count_nonzero(st.collided & ~was))
        if w.cfg.duration_ticks and n >= w.cfg.duration_ticks:
            w.stopped = True
        readings = None
        if sense:
            readings, _, enc = self.sensors.read(n, ids, w.bodies, st.pose, st.collided, st.rolled_m, view)
            self.sensors.commit_counts(n, ids, enc)
        self.last = None  # step()'s messages are not built here
        return ArrayStep(n, ids, w.bodies, st.pose, st.collided, st.rolled_m, readings)

    def _step_fused(
        self, cmd: np.ndarray, ids: list[int], view: WorldView, z: np.ndarray, acc: np.ndarray
    ) -> ArrayStep:
        """:meth:`step_arrays`' tick in one compiled call: the world's proposal, the collision
        check, the commit and the sensors, with this tick's normals ``z`` and encoder counts ``acc``."""
        w = self.world
        bodies, st, fx = w.bodies, w.state, self._fixed
        if fx is None or fx[0] is not bodies or fx[1] is not view.scene:
            doors = self.collide.doors_of(bodies)
            args = fused.fixed_args(
                view.scene,
                bodies,
                drive_table(bodies),
                doors,
                w.cfg.period_ms / 1000.0,
                self.sensors.params.gps_offset_m,
            )
            fx = self._fixed = (bodies, view.scene, args)
        pose, out, rolled, hit, prox, legacy, compass, gps, enc, laser_m = fused.tick(
            floats(st.pose), floats(st.motor_out), cmd, w.motion_normals(), z, acc, fx[2]
        )
        n, was = w.took(cmd, pose, out, rolled, hit)
        if np.count_nonzero(hit):  # the robots that hit this tick and had not the tick before
            w.collisions += int(np.count_nonzero(hit & ~was))
        if w.cfg.duration_ticks and n >= w.cfg.duration_ticks:
            w.stopped = True
        readings = read_all_readings(view.scene, bodies, pose, hit, prox, legacy, compass, gps, enc, laser_m)
        self.sensors.commit_counts(n, ids, enc.copy())
        self.last = None
        return ArrayStep(n, ids, bodies, pose, hit, rolled, readings)

    def array_ids(self) -> list[int]:
        """The robots' ids in the order :meth:`step_arrays` takes and gives them."""
        return list(self.world.arrays())
