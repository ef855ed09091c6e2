"""Writing an agent: a policy from readings to commands, and the host that runs many of them.

The one module an agent's author imports: the agent, its command, its robot's spec and the
reading types are all here. An agent is any object with ``spec()`` and ``on_sensors(reading, heard)``::

    from iw_zenoh.agent import Command, Heard, Readings, Spec

    class Forward:
        def spec(self) -> Spec:
            return Spec("fwd")
        def on_sensors(self, reading: Readings, heard: list[Heard]) -> Command:
            return Command.from_velocity(0.3, 0.0)  # 0.3 m/s ahead, no turn

It may also have the optional hooks of :mod:`iw_zenoh.agent.hooks` (:class:`OnRegistered`,
:class:`OnChair`, :class:`AttachTo`, :class:`OnState`: the world's committed state of the tick,
handed to it just before that tick's ``on_sensors``, as a learned policy needs, ``iwz agent
policy``; :class:`OnDrive`: a chair a person drives, ``docs/driving.md``, and :class:`DrivesNow`:
its driver's input answered at once, between ticks). ``iwz agent
./my_agent.py:Name`` runs one from the user's own file (``docs/first-agent.md``; its ``args.seed``
is the seed the run hands it), and ``--spec chair.toml`` lays a spec file's fields over its robot
(``docs/spec.md``).

An :class:`AgentHost` registers every agent's robot with the world, hands each one its readings
(and what its robot heard on the radio) every tick, and publishes its actions and messages. One
process may host any number of agents; in lock-step the host answers a tick once every robot's
readings (and the radio's batch) for it have arrived.

A host of a few robots reads each robot's own sensors key and answers on each robot's actions
key. A host of many (``batched=True``; ``iwz agent`` chooses it from BATCH_FROM robots) reads its
sensors shards' batches and answers every robot in one :class:`ActionBatch`: a tick then costs it
a few messages instead of two per robot (a thousand messages a tick cost a Python process tens
of milliseconds).
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass, field
from typing import Protocol

from iw_zenoh import keys
from iw_zenoh.agent.hooks import AttachTo, DrivesNow, OnChair, OnDrive, OnRegistered, OnState, attached_to
from iw_zenoh.agent.hosting import Command, InlineAnswers, Outbox, WorldRegistration
from iw_zenoh.agent.places import point_arg, points_arg, pose_arg
from iw_zenoh.bus import Asked, Bus, Delivery, Handle, Inbox
from iw_zenoh.convert import spec_from_msg, spec_to_msg
from iw_zenoh.core.modes import Mode
from iw_zenoh.core.motor import MAX_POWER
from iw_zenoh.core.spec import BumperSpec, IrSensorSpec, LaserSpec, RobotSpec, SensorNoise, prototype_chair
from iw_zenoh.errors import DecodeError, IwError, ProtocolError
from iw_zenoh.messages import (
    ChairReading,
    DriveInput,
    DriveState,
    Event,
    EventKind,
    Heard,
    RadioBatch,
    RegisterReply,
    RegisterRequest,
    SensorReading,
    WorldInfo,
    WorldState,
    decode,
    encode,
    readings_of,
)
from iw_zenoh.messages.robot import Pose
from iw_zenoh.process.runtime import NodeIO
from iw_zenoh.ticks import TickWindow

__all__ = [
    "BATCH_FROM",
    "MAX_POWER",
    "Agent",
    "AgentHost",
    "AttachTo",
    "BumperSpec",
    "ChairReading",
    "Command",
    "DrivesNow",
    "Heard",
    "IrSensorSpec",
    "LaserSpec",
    "OnChair",
    "OnDrive",
    "OnRegistered",
    "OnState",
    "Pose",
    "Readings",
    "RegistrationRefused",
    "SensorNoise",
    "Spec",
    "point_arg",
    "points_arg",
    "pose_arg",
    "prototype_chair",
]

Spec = RobotSpec  # a robot's spec: its body, start, top speed, sensors and noise (docs/spec.md)
Readings = SensorReading  # one tick's readings of a robot (``reading.pose``, ``reading.proximity_m``...)

logger = logging.getLogger(__name__)

BATCH_FROM = 8  # robots in one host from which `iwz agent` reads and answers in batches
SILENT_S = 2.0  # no readings this long: the host asks the world whether its robots are still there
UNANSWERED_S = 0.3  # and asks again this soon when no world answered
# sensor batches waiting at most (a shard's batch a tick, each up to a few hundred robots' readings):
# only each robot's newest reading is answered, so a host that fell behind needs the newest ticks'
BATCHES_KEPT = 1024
DRIVES_KEPT = 256  # drivers' inputs waiting at most (a flood costs this much; 20 Hz per driver is the norm)
HEARD_KEPT = 64  # radio batches, fresh counts kept for ticks not answered yet (robots gone answer none)


class Agent(Protocol):
    """A robot's controller (optional hooks: :class:`OnRegistered`, :class:`OnChair`, :class:`AttachTo`)."""

    def spec(self) -> RobotSpec:
        """The robot to register."""

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """This tick's command, from this tick's readings and what was heard."""


class RegistrationRefused(IwError):
    """The world refused a robot; the message says why."""


@dataclass
class _Hosted:
    agent: Agent
    robot_id: int
    spec: RobotSpec
    reading: SensorReading | None = None
    answered: int = -1
    extra: dict[str, object] = field(default_factory=dict)


class AgentHost:
    """Runs agents on the bus.

    Args:
        bus: The bus.
        sim: Simulation name.
        name: This process's agent name (its liveliness token; the world stops its robots when
            the token goes).
        batched: Read sensor batches and answer in one ActionBatch a tick (for many robots).
        io: The process's node handle (default: a new one, role ``agent``).
    """

    def __init__(self, bus: Bus, sim: str, name: str, *, batched: bool = False, io: NodeIO | None = None) -> None:
        self.io = io or NodeIO(bus, sim, "agent", name)
        self.sim = sim
        self.name = name
        self.hosted: dict[int, _Hosted] = {}
        self.batched = batched
        # a tick's inputs, answered on the thread that delivers the last of them while run() runs
        self.inline = InlineAnswers(self._answer, self.io.wake)
        self.readings = Inbox(wake=self.inline)  # fed one key per hosted robot
        # batched: every shard's batch, subscribed before any registration (no first tick lost)
        self.batches = (
            self.io.inbox(keys.all_sensor_batches(sim), maxlen=BATCHES_KEPT, wake=self.inline) if batched else None
        )
        self.radio = self.io.inbox(keys.radio(sim), wake=self.inline)
        self.radio_alive: set[str] = set()
        self._heard: dict[int, dict[int, list[Heard]]] = {}
        self._fresh: dict[int, int] = {}  # tick -> how many hosted robots have that tick's readings
        self.window = TickWindow()  # a reading or radio batch from too far ahead is refused
        self.lockstep = False
        self._requests = 0
        self.outbox = Outbox(bus, sim, name, batched=batched)
        # a robot removed while this process was stopped or cut off is registered again when it
        # is back: it learns from the removed event, or (the event missed) from a silence of
        # SILENT_S and the world's description that no longer lists it
        self.removed = self.io.inbox(keys.event(sim, EventKind.REMOVED))
        self._subscribed: dict[int, Handle] = {}
        self._robot_of_key: dict[str, int] = {}  # each subscribed sensors key's robot (not parsed every tick)
        self._last_reading = time.monotonic()
        self._asked_info: Asked | None = None
        self._asked_at = 0.0
        self._orphans: list[Agent] = []  # robots removed, to register again
        self._retry_at = 0.0  # when to try the orphans again
        self.chairs: Inbox | None = None  # real chairs' own readings, for agents that drive one (attach)
        self._chair_keys: set[int] = set()  # the robots whose chair readings are subscribed
        self.states: Inbox | None = None  # the world's states, once an agent with on_state is hosted
        self.state: WorldState | None = None  # the newest state taken
        # drivers' inputs, for agents that accept a driver (``on_drive``; docs/driving.md): answered
        # on the delivering thread too, at once (``drive_now``), not at the next tick
        self.drives = Inbox(maxlen=DRIVES_KEPT, wake=self.inline, newest_only=True)
        self._drive_subs: dict[int, Handle] = {}
        bus.watch_alive(keys.all_alive(sim), self._on_alive)
        self.io.alive()

    def _on_alive(self, key: str, alive: bool) -> None:
        parts = keys.alive_parts(key)
        if parts and parts[0] == "radio":
            (self.radio_alive.add if alive else self.radio_alive.discard)(parts[1])

    def add(self, agent: Agent, *, timeout_s: float = 15.0) -> int:
        """Registers an agent's robot; returns its id.

        Raises:
            RegistrationRefused: With the world's reason, or when no world answers.
        """
        self._requests += 1
        asked = agent.spec()
        self._want_states(agent)
        req = RegisterRequest(spec=spec_to_msg(asked), agent=self.name, request_id=f"{os.getpid()}-{self._requests}")
        early, early_box = self._listen_early(asked)
        reply, spec = self._accepted(self._ask(req, timeout_s), timeout_s, early)
        rid = reply.robot_id
        if early is not None and rid != asked.id:
            if asked.id == 0 and rid not in self._subscribed:
                # its own key before every robot's is dropped, so no reading falls between them
                self._subscribed[rid] = self._subscribe_sensors(rid)
            early.undeclare()
            early = None
        self.window.anchor(reply.tick, time.monotonic_ns())  # the world's own word for its tick
        if not self.hosted:  # learn the world's mode once (lock-step changes when we answer)
            for data in self.io.bus.query(keys.info(self.sim), timeout_s=timeout_s):
                try:
                    self.lockstep = decode(data, WorldInfo).mode == Mode.LOCKSTEP
                except DecodeError as e:
                    self.io.bad_message(keys.info(self.sim), e)
        self.hosted[rid] = _Hosted(agent, rid, spec)
        if early_box is not None:
            # what every robot's key brought of this one, taken before anything its own key
            # brought (the host's loop drains those later): the two subscriptions deliver on
            # threads of their own, and a tick's reading and the sensors' correction of it, taken
            # in the wrong order, would leave the first as the tick's (a copy delivered by both
            # is taken twice: a tick counts once, _take)
            for d in early_box.drain():
                if keys.robot_id_of(d[0]) == rid:
                    self._reading_in(d, self.hosted[rid])
        if early is not None:
            self._subscribed[rid] = early
        elif not self.batched and rid not in self._subscribed:
            self._subscribed[rid] = self._subscribe_sensors(rid)
        self._accept_driver(agent, rid)
        if isinstance(agent, OnRegistered):
            agent.on_registered(rid, spec)
        return rid

    def _listen_early(self, asked: RobotSpec) -> tuple[Handle | None, Inbox | None]:
        """Listens for a robot's readings before it is asked for: in lock-step the world waits
        for the robot from the first tick after it is accepted, and readings published before a
        subscription made after the answer would be lost (the world then waits out its whole
        timeout). Its own key when its id is asked for; else every robot's, into an inbox of
        their own that wakes nobody (see :meth:`add`), until the answer names it."""
        if self.batched:
            return None, None
        if asked.id > 0:
            return (self._subscribe_sensors(asked.id) if asked.id not in self._subscribed else None), None
        box = Inbox()
        return self.io.bus.subscribe(keys.all_sensors(self.sim), box), box

    def _accepted(
        self, reg: WorldRegistration, timeout_s: float, early: Handle | None
    ) -> tuple[RegisterReply, RobotSpec]:
        """The world's answer that accepts the robot, with the spec it accepted (naming its id:
        a world's "ok" does); else RegistrationRefused, ``early`` given up."""

        def refused(why: str) -> RegistrationRefused:
            if early is not None:
                early.undeclare()
            return RegistrationRefused(why)

        try:
            reply = reg.reply()
            spec = spec_from_msg(reply.spec) if reply is not None and reply.ok and reply.spec is not None else None
        except IwError as e:  # an answer that does not decode, or a spec the world should not have sent
            raise refused(f"the answer on {reg.key} is refused: {e}") from None
        if reply is None:
            raise refused(
                f"no world answered on {reg.key} within {timeout_s:g} s; "
                f"is `iwz world` running with --sim {self.sim}? (secured: does the policy name {self.name!r} an agent?)"
            )
        if not reply.ok:
            raise refused(reply.reason)
        if reply.robot_id < 1 or spec is None:
            raise refused(f"the answer on {reg.key} accepts the robot but names no id or spec")
        return reply, spec

    def _want_states(self, agent: Agent) -> None:
        """Subscribes the world's states (before the robot is asked for: its first tick's state
        is not missed) when the agent has ``on_state``."""
        if self.states is None and isinstance(agent, OnState):
            self.states = self.io.inbox(keys.state(self.sim), wake=self.inline)

    def _accept_driver(self, agent: Agent, robot_id: int) -> None:
        """Listens for drivers' inputs to a robot whose agent accepts a driver (``on_drive``)."""
        if isinstance(agent, OnDrive) and robot_id not in self._drive_subs:
            self._drive_subs[robot_id] = self.io.bus.subscribe(keys.drive(self.sim, robot_id), self.drives)

    def _publish_drive(self, h: _Hosted) -> None:
        """A driven chair's drive messages of this tick (``drive_messages()``): its drive state, and
        the inputs a replayed trace gave (recorded as a live driver's would be)."""
        for m in h.agent.drive_messages() if isinstance(h.agent, OnDrive) else []:
            key = keys.driving if isinstance(m, DriveState) else keys.drive
            self.io.bus.publish(key(self.sim, h.robot_id), encode(m))

    def _drive_now(self) -> None:
        """Real time: each driven chair whose driver's newest input changed its command answers its
        last tick again at once (``drive_now``); the world applies it at its next step."""
        if self.lockstep:
            return  # lock-step answers on ticks only: a run replays exactly
        sent = False
        for rid in self._drive_subs:
            h = self.hosted.get(rid)
            r = h.reading if h is not None else None
            if h is None or r is None or r.tick != h.answered or not isinstance(h.agent, DrivesNow):
                continue
            cmd = h.agent.drive_now()
            if cmd is not None:
                self.outbox.command(rid, cmd.resolved(h.spec), tick=r.tick, sim_time_ns=r.sim_time_ns)
                self._publish_drive(h)
                sent = True
        if sent:
            self.outbox.flush()

    def _subscribe_sensors(self, robot_id: int) -> Handle:
        """Subscribes a robot's own sensors key into :attr:`readings`."""
        key = keys.sensors(self.sim, robot_id)
        self._robot_of_key[key] = robot_id
        return self.io.bus.subscribe(key, self.readings)

    def _ask(self, req: RegisterRequest, timeout_s: float) -> WorldRegistration:
        """Asks the world for a robot on this agent's own key (the one a secured router lets only
        it ask on); the world may still be starting: asked again until it answers."""
        reg = WorldRegistration(
            self.io.bus,
            self.sim,
            req,
            now=time.monotonic(),
            patience_s=timeout_s,
            query_timeout_s=min(1.0, timeout_s),
            own_key=True,
        )
        while not reg.poll(time.monotonic()) and not self.io.stop.is_set():
            reg.wait(self.io.stop, time.monotonic())
        return reg

    def _in_window(self, key: str, tick: int) -> bool:
        """Whether a tick is within the window; one that is not is refused with a bad-message event."""
        why = self.window.refuse(tick, time.monotonic_ns())
        if why:
            self.io.bad_message(key, ProtocolError(why))
        return not why

    def _check_removed(self, now: float) -> None:
        """Registers again the robots the world removed (see SILENT_S); a robot removed by a
        control command (an operator's choice) is let go."""
        for d in self.removed.drain():
            ev = self.io.decode(d, Event)
            h = self.hosted.get(ev.robot_id) if ev is not None else None
            if ev is not None and h is not None:
                self._let_go(ev.robot_id)
                if "by control" in ev.reason:
                    logger.warning("robot %d was removed by control: not registered again", ev.robot_id)
                else:
                    self._orphans.append(h.agent)
        if self._asked_info is not None and self._asked_info.answered():
            if not self._asked_info.replies:  # no world, or this process not connected again yet
                self._asked_at = now - SILENT_S + UNANSWERED_S
            self._gone_from_info(self._asked_info.replies)
            self._asked_info = None
        silent = now - max(self._last_reading, self._asked_at) > SILENT_S
        if self.hosted and silent and self._asked_info is None:
            self._asked_at = now
            self._asked_info = self.io.bus.ask(keys.info(self.sim), timeout_s=1.0)
        if self._orphans and now >= self._retry_at:
            self._register_again(now)

    def _gone_from_info(self, replies: list[bytes]) -> None:
        """The hosted robots the world's description no longer lists become orphans."""
        for data in replies[:1]:
            try:
                info = decode(data, WorldInfo)
            except DecodeError:
                return
            there = {(r.id, r.name) for r in info.robots}
            for rid, h in list(self.hosted.items()):
                if (rid, h.spec.name) not in there:
                    logger.warning("robot %d is no longer in the world: registering it again", rid)
                    self._let_go(rid)
                    self._orphans.append(h.agent)

    def _let_go(self, robot_id: int) -> None:
        """Forgets a hosted robot the world no longer has, and stops listening for its readings
        (registered again, it gets a subscription of its own: none is left behind)."""
        del self.hosted[robot_id]
        self._robot_of_key.pop(keys.sensors(self.sim, robot_id), None)
        sub = self._subscribed.pop(robot_id, None)
        if sub is not None:
            sub.undeclare()
        drive = self._drive_subs.pop(robot_id, None)
        if drive is not None:
            drive.undeclare()

    def _register_again(self, now: float) -> None:
        """Registers the orphans again; one refused (its start place taken) is tried again later."""
        orphans, self._orphans = self._orphans, []
        for agent in orphans:
            try:
                attach_to = attached_to(agent)  # a robot another process registers: wait for it
                rid = self.attach(agent, attach_to, timeout_s=2.0) if attach_to else self.add(agent, timeout_s=2.0)
                logger.warning("robot %d registered again for %s", rid, agent.spec().name)
            except RegistrationRefused as e:
                logger.warning("registering %s again: %s; trying again later", agent.spec().name, e)
                self._orphans.append(agent)
                self._retry_at = now + SILENT_S

    def attach(self, agent: Agent, robot_id: int, *, timeout_s: float = 30.0) -> int:
        """Drives a robot that another process registered (a real chair's serial bridge).

        Nothing is registered: waits until the world lists the robot, then hands the agent its
        readings and publishes its actions, as for a robot it registered. An agent with
        ``on_chair(ChairReading)`` also gets the chair's own readings (``robot/{id}/chair``).
        The world does not wait for this agent in lock-step (the bridge answers for the robot).

        Raises:
            RegistrationRefused: The world did not list the robot within ``timeout_s``.
        """
        self._want_states(agent)
        if robot_id not in self._subscribed:
            self._subscribed[robot_id] = self._subscribe_sensors(robot_id)
        deadline = time.monotonic() + timeout_s
        spec: RobotSpec | None = None
        while spec is None:
            for data in self.io.bus.query(keys.info(self.sim), timeout_s=1.0):
                info = decode(data, WorldInfo)
                self.lockstep = info.mode == Mode.LOCKSTEP
                spec = next((spec_from_msg(r) for r in info.robots if r.id == robot_id), spec)
            if spec is None:
                if time.monotonic() > deadline or self.io.stop.is_set():
                    raise RegistrationRefused(f"no robot {robot_id} in the world within {timeout_s:g} s to attach to")
                self.io.stop.wait(0.2)
        self.hosted[robot_id] = _Hosted(agent, robot_id, spec)
        if isinstance(agent, OnChair) and robot_id not in self._chair_keys:
            self.chairs = self.chairs or Inbox(wake=self.io.wake)
            self._chair_keys.add(robot_id)
            self.io.bus.subscribe(keys.chair(self.sim, robot_id), self.chairs)
        self._accept_driver(agent, robot_id)
        if isinstance(agent, OnRegistered):
            agent.on_registered(robot_id, spec)
        return robot_id

    def _collect(self) -> None:
        for d in self.chairs.drain() if self.chairs is not None else []:
            c = self.io.decode(d, ChairReading)
            h = self.hosted.get(c.robot_id) if c is not None else None
            if c is not None and h is not None and isinstance(h.agent, OnChair):
                h.agent.on_chair(c)
        for d in self.states.drain() if self.states is not None else []:
            st = self.io.decode(d, WorldState)
            if st is not None and self._in_window(d[0], st.tick) and (self.state is None or st.tick > self.state.tick):
                self.state = st
        for d in self.drives.drain():
            m = self.io.decode(d, DriveInput)
            rid = keys.robot_id_of(d[0])
            h = self.hosted.get(rid) if rid is not None else None
            if m is not None and m.robot_id != rid:
                self.io.bad_message(d[0], ProtocolError(f"a drive input for robot {m.robot_id} on robot {rid}'s key"))
            elif m is not None and h is not None and isinstance(h.agent, OnDrive):
                h.agent.on_drive(m)
        for d in self.radio.drain():
            b = self.io.decode(d, RadioBatch)
            if b is not None and self._in_window(d[0], b.tick):
                self._heard[b.tick] = {h.robot_id: h.messages for h in b.hear}
        if len(self._heard) > HEARD_KEPT:  # only the newest ticks are ever answered
            for t in sorted(self._heard)[:-HEARD_KEPT]:
                del self._heard[t]
        for d in self.readings.drain():
            rid = self._robot_of_key.get(d[0]) or keys.robot_id_of(d[0])
            h = self.hosted.get(rid) if rid is not None else None
            if h is not None:
                self._reading_in(d, h)
        if self.batches is not None:
            for d in self.batches.drain():
                try:  # only this host's robots' readings are decoded
                    mine = readings_of(d[1], self.hosted)
                except DecodeError as e:
                    self.io.bad_message(d[0], e)
                    continue
                if mine and self._in_window(d[0], max(r.tick for r in mine)):
                    for r in mine:
                        self._take(self.hosted[r.robot_id], r)

    def _reading_in(self, d: Delivery, h: _Hosted) -> None:
        """A delivery on hosted robot ``h``'s sensors key: decoded, checked, taken."""
        r = self.io.decode(d, SensorReading)
        if r is not None and r.robot_id != h.robot_id:
            self.io.bad_message(d[0], ProtocolError(f"a reading of robot {r.robot_id} on robot {h.robot_id}'s key"))
        elif r is not None and self._in_window(d[0], r.tick):
            self._take(h, r)

    def _take(self, h: _Hosted, r: SensorReading) -> None:
        """Keeps a robot's newest reading and counts the tick's fresh ones; a second reading of a
        tick not answered yet replaces the first (the sensors' correction of readings they sent
        before the world held that tick)."""
        self._last_reading = time.monotonic()
        if h.reading is None or r.tick > h.reading.tick:
            h.reading = r
            if r.tick > h.answered:
                self._fresh[r.tick] = self._fresh.get(r.tick, 0) + 1
                if len(self._fresh) > HEARD_KEPT:  # ticks never answered (a robot whose readings stopped)
                    del self._fresh[min(self._fresh)]
        elif r.tick == h.reading.tick > h.answered:
            h.reading = r

    def _ready(self) -> int | None:
        """The tick to answer now, or None (counts kept by _collect: no scan of every robot)."""
        if not self._fresh:
            return None
        n = max(self._fresh)
        if self.lockstep:
            if self._fresh[n] < len(self.hosted):
                return None  # wait for every robot's readings of tick n
            if self.radio_alive and n not in self._heard:
                return None  # and for the radio's batch, so heard messages are the same every run
            if self.states is not None and (self.state is None or self.state.tick < n):
                return None  # and for the tick's state, when an agent is handed it
        return n

    def step(self, timeout_s: float = 0.2) -> bool:
        """Answers the newest tick if ready; waits up to ``timeout_s`` for input otherwise."""
        with self.inline.lock:
            self._check_removed(time.monotonic())
            if self._answer():
                return True
        self.io.wait(timeout_s)
        with self.inline.lock:
            return self._answer()

    def _answer(self) -> bool:
        """Answers the newest tick if ready (under ``inline.lock``); False when not ready."""
        self._collect()
        n = self._ready()
        if n is None:
            self._drive_now()
            return False
        heard_now = self._heard.get(n, {})
        for h in self.hosted.values():
            r = h.reading
            if r is None or r.tick <= h.answered:
                continue
            if self.state is not None and isinstance(h.agent, OnState):
                h.agent.on_state(self.state)
            cmd = h.agent.on_sensors(r, heard_now.get(h.robot_id, [])).resolved(h.spec)  # a velocity: powers
            self.outbox.command(h.robot_id, cmd, tick=r.tick, sim_time_ns=r.sim_time_ns)
            if h.robot_id in self._drive_subs:  # a chair a person drives: what it did with the input
                self._publish_drive(h)
            h.answered = r.tick
        self.outbox.flush()
        if self._heard:  # tick n's stays: a robot whose reading of n comes later is answered with it
            for t in [t for t in self._heard if t < n]:
                del self._heard[t]
        for t in [t for t in self._fresh if t <= n]:
            del self._fresh[t]
        return True

    def run(self) -> None:
        """Answers ticks until stopped: on the thread that delivers a tick's last input
        (:class:`~iw_zenoh.agent.hosting.InlineAnswers`), or on this one when that thread found it busy;
        an agent's error on a delivering thread is raised here."""
        self.inline.active = True
        try:
            while not self.io.stop.is_set():
                self.step()
                if self.inline.failure is not None:
                    raise self.inline.failure
        finally:
            self.inline.active = False
