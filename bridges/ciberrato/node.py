"""``iwz bridge ciberrato``: unmodified Ciber-Rato / Intellwheels agents and viewers join a Zenoh
simulation over the legacy XML/UDP protocol.

Each legacy client gets a socket of its own (the reply and everything after come from it, as the
legacy server does); robots become robots of the Zenoh world (registered through the world's
queryable, driven by their actions, fed Measures from the Zenoh sensor readings every tick, in
every simulator state); viewers get the reply, the lab and grid on request, and one robot state
per robot per tick. A bad datagram is answered where the protocol allows (a refusal) or dropped
with an event naming the peer and the reason; it never stalls another client.
"""

from __future__ import annotations

import argparse
import collections
import logging
import math
import os
import selectors
import socket
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from iw_zenoh import keys
from iw_zenoh.bus import Asked, ZenohBus
from iw_zenoh.cliargs import add_common_arguments, net_from_args
from iw_zenoh.convert import grid_from_msg, lab_from_msg, spec_to_msg
from iw_zenoh.core.modes import Mode as WorldMode
from iw_zenoh.core.modes import Profile
from iw_zenoh.core.params import SimParameters
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.errors import IwError, ProtocolError
from iw_zenoh.maps import grid_to_xml, lab_to_xml, load_parameters
from iw_zenoh.messages import (
    ActionBatch,
    Actions,
    Control,
    EventKind,
    LabMsg,
    LegacyRefusedData,
    PoseReport,
    RadioBatch,
    RegisterReply,
    RegisterRequest,
    Say,
    SensorBatch,
    SensorReading,
    Tick,
    Verdict,
    WorldInfo,
    WorldState,
    decode,
    encode,
)
from iw_zenoh.nodes.base import NodeIO, install_stop_signals, setup_logging

from .codec import (
    Measures,
    Score,
    build_measures,
    build_refusal,
    build_reply,
    build_robot_state,
    parse_actions,
    parse_registration,
    parse_viewer_command,
    registration_spec,
)
from .pacing import Pacer
from .scoring import FreeSpace, Mode, PathLength, RobotGame, StepInput

__all__ = ["Bridge", "main"]

logger = logging.getLogger(__name__)

RECV_BYTES = 4096
GPS_OFFSET = (840.1877, 394.3829)  # the legacy simulator's GPS origin on glibc, until a reset
NO_MEASUREMENT: dict[str, Any] = {"ir": 0.0, "compass": 0.0, "ground": -1, "collision": False, "beacon": None}
FLOOD_PER_S = 400  # datagrams a second one peer (address and port) may send before the rest are dropped
CATCH_UP = 2  # readings of one robot sent at once after a stall (the rest are stale)
POLL_S = 0.001  # the loop looks at the bus queues at least this often
MIN_LEAD_NS = 2_000_000  # paced Measures are built at least this long before they are due
EVENT_EVERY_S = 1.0  # at most one refusal event a second per peer
WORLD_WAIT_S = 10.0  # a registration no world answers is asked again this long (a world still starting)
ASK_AGAIN_S = 0.2  # ... at most this often


@dataclass
class _Pending:
    """A legacy registration waiting for the world's answer."""

    asked: Asked  # the query in flight
    payload: bytes  # the request, to ask again while no world answers
    since: float  # monotonic time of the client's registration
    asked_at: float  # monotonic time of the last ask
    spec: RobotSpec
    params: SimParameters
    nb: int  # NBeacons in the reply
    nb_sensed: int  # beacons the robot will sense


class FloodGuard:
    """Counts each peer's datagrams per second. Per address *and port*: a course's agents all
    send from one machine's address, and must not share one budget.

    Args:
        per_s: Datagrams a peer may send in a second before the rest are refused.
    """

    def __init__(self, per_s: int) -> None:
        self.per_s = per_s
        self._rate: dict[tuple[str, int], tuple[float, int]] = {}

    def over(self, peer: tuple[str, int], now: float) -> bool:
        """Counts one datagram from ``peer`` at ``now`` (seconds); whether it is over the limit."""
        if len(self._rate) > 4096:  # forget peers quiet for a second (spoofed ports cost no memory)
            self._rate = {p: v for p, v in self._rate.items() if now - v[0] < 1.0}
        start, n = self._rate.get(peer, (now, 0))
        if now - start >= 1.0:
            start, n = now, 0
        self._rate[peer] = (start, n + 1)
        return n + 1 > self.per_s


@dataclass
class Client:
    """One legacy client and its own socket."""

    kind: str  # robot, viewer, panel
    addr: tuple[str, int]
    sock: socket.socket
    robot_id: int = 0
    name: str = ""
    left: float = 0.0
    right: float = 0.0
    leds: dict[str, bool] = field(default_factory=dict)
    reading: SensorReading | None = None
    heard: list[tuple[int, str]] = field(default_factory=list)
    sent_tick: int = -1
    requests: list[str] = field(default_factory=list)  # sensor requests of this cycle
    finished: bool = False  # EndLed seen (or the game says Finished): the robot never moves again
    game: RobotGame | None = None  # its legacy state and score
    start: tuple[float, float] = (0.0, 0.0)  # its grid position
    returning_now: bool = False  # a ReturningLed="On" arrived this cycle
    pose: tuple[float, float] = (0.0, 0.0)  # its last committed centre
    fifos: dict[str, collections.deque[Any]] = field(default_factory=dict)  # latency queues
    n_beacons: int = 0  # beacon sensors: the beacons there were when it registered (legacy)


class Bridge:
    """The bridge's state and its I/O (UDP on one side, the bus on the other).

    Args:
        bus: The bus.
        sim: Simulation name.
        bind: Address to listen on (loopback by default).
        port: Registration port (6000 for unmodified clients).
        params: The legacy parameters clients are told.
        name: Process name (its liveliness token drives the world's safety rules).
        scoring: The legacy scoring mode.
        pace: In a real-time world, send each tick's Measures at a steady offset from the tick's
            start (see :mod:`.pacing`) rather than as soon as the readings arrive.
    """

    def __init__(
        self,
        bus: ZenohBus,
        sim: str,
        *,
        bind: str = "127.0.0.1",
        port: int = 6000,
        params: SimParameters | None = None,
        name: str = "ciberrato",
        scoring: Mode = Mode.COMPETITIVE,
        pace: bool = True,
    ) -> None:
        self.bus = bus
        self.sim = sim
        self.bind = bind
        self.params = params or SimParameters()
        self.name = name
        self.scoring = scoring
        self.io = NodeIO(bus, sim, "agent", name)  # its robots stop if this process goes
        self.sel = selectors.DefaultSelector()
        self.reception = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.reception.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.reception.bind((bind, port))
        self.reception.setblocking(False)
        self.port = self.reception.getsockname()[1]
        self.sel.register(self.reception, selectors.EVENT_READ, None)
        self.clients: dict[tuple[str, int], Client] = {}
        self.by_robot: dict[int, Client] = {}
        self.info: WorldInfo | None = None
        self.running = True
        # Zenoh's own queues, polled by the UDP loop every millisecond: no Python callback thread
        # competing for the interpreter lock with the loop 100 times a cycle (that contention,
        # not the work, was most of the Measures jitter at 100 robots)
        self.states = bus.queue(keys.state(sim), 64)
        self.ticks = bus.queue(keys.tick(sim), 64)
        # every shard's batch: one message a tick instead of one per robot
        self.readings = bus.queue(keys.all_sensor_batches(sim), 256)
        self._outbox: dict[int, Actions] = {}  # robot -> newest actions not yet sent
        self._registering: dict[tuple[str, int], _Pending] = {}
        self._carriers: set[int] = set()  # legacy robots accepted here that carry a beacon
        self.pace = pace
        self.finished_at: int | None = None  # the simulator's Time frozen at SimTime, once reached
        self._pacer: Pacer | None = None
        self._paced_tick = -1
        self._due: dict[int, tuple[int, list[tuple[Client, SensorReading]]]] = {}  # tick -> (when, to send)
        self._built: dict[int, list[tuple[Client, bytes]]] = {}  # tick -> its Measures, built ahead
        self._lead_ns = MIN_LEAD_NS  # how long before their time Measures are built
        self.hears = bus.queue(keys.radio(sim), 256)  # the radio's batch: one message a tick
        self.infos = bus.queue(keys.info(sim), 16)
        self.verdicts = bus.queue(keys.verdict(sim), 64)  # which collisions were walls, which robots
        self._hits: dict[int, dict[int, tuple[bool, bool]]] = {}  # tick -> robot -> (wall, robot)
        self._space: tuple[LabMsg, list[FreeSpace]] | None = None
        self._flood = FloodGuard(FLOOD_PER_S)
        self._hit: dict[int, bool] = {}
        self._collisions: dict[int, int] = {}
        self._last_event: dict[tuple[str, str], float] = {}
        self.io.alive()
        bus.token(keys.alive(sim, "bridge", name))

    # --- legacy side ---------------------------------------------------------------------

    def _refuse(self, peer: tuple[str, int], reason: str) -> None:
        """Logs and reports a refused datagram, at most once per peer and reason every EVENT_EVERY_S
        (a flood must not turn into a flood of log lines)."""
        key = (f"{peer[0]}:{peer[1]}", reason[:40])
        now = time.monotonic()
        if now - self._last_event.get(key, 0.0) >= EVENT_EVERY_S:
            self._last_event[key] = now
            logger.warning("refused a datagram from %s:%d: %s", peer[0], peer[1], reason)
            peer_s = f"{peer[0]}:{peer[1]}"
            self.io.event(EventKind.LEGACY_REFUSED, f"{peer_s}: {reason}", LegacyRefusedData(peer=peer_s))

    def _new_socket(self) -> socket.socket:
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.bind((self.bind, 0))
        s.setblocking(False)
        return s

    def _world_info(self) -> WorldInfo | None:
        if self.info is None:
            for data in self.bus.query(keys.info(self.sim), timeout_s=2.0):
                try:
                    self.info = decode(data, WorldInfo)
                except IwError:
                    continue
        return self.info

    def on_registration(self, data: bytes, peer: tuple[str, int]) -> None:
        """A datagram on the registration port."""
        if peer in self.clients and self.clients[peer].kind == "robot":
            self._refuse(peer, "a second registration from a registered address")
            self.reception.sendto(build_refusal(), peer)
            return
        try:
            reg = parse_registration(data)
        except ProtocolError as e:
            self._refuse(peer, str(e))  # the legacy server answers nothing to what does not parse
            return
        info = self._world_info()
        nb = len(info.lab.beacons) if info else 0
        params = self.params
        if info is not None:
            params = SimParameters(**{**params.__dict__, "cycle_time_ms": max(1, info.period_ns // 1_000_000)})
        if reg.kind in ("view", "panel"):
            sock = self._new_socket()
            c = Client("viewer" if reg.kind == "view" else "panel", peer, sock)
            self.clients[peer] = c
            self.sel.register(sock, selectors.EVENT_READ, c)
            sock.sendto(build_reply(params, n_beacons=nb), peer)
            return
        try:
            spec = registration_spec(reg, self.params)
        except IwError as e:
            self._refuse(peer, str(e))
            sock = self._new_socket()
            sock.sendto(build_refusal(), peer)
            sock.close()
            return
        if peer in self._registering:
            return  # asked already; the answer is on its way (a client repeating itself)
        # beacons robots carry: those the world's description lists, and those accepted or being
        # registered here since (the description is published a moment later)
        carried = {r.id for r in info.robots if r.beacon_height is not None} if info else set()
        carried |= self._carriers & set(self.by_robot)
        n_carried = len(carried) + sum(1 for p in self._registering.values() if p.spec.beacon_height_m is not None)
        if reg.kind == "beacon" and (nb or n_carried):
            # the legacy rule: one beacon at most, and a RobotBeacon becomes the lab's beacon
            self._refuse(peer, "a RobotBeacon is refused when the lab already has a beacon")
            sock = self._new_socket()
            sock.sendto(build_refusal(), peer)
            sock.close()
            return
        # beacon sensors are made for the beacons there are now (later RobotBeacons: none)
        nb_sensed = nb + n_carried
        req = RegisterRequest(
            spec=spec_to_msg(spec),
            agent=self.name,
            request_id=f"{os.getpid()}-{peer[0]}-{peer[1]}-{time.monotonic_ns()}",
        )
        # the world's answer is awaited by the loop, not here: the other clients' Measures go on
        payload = encode(req)
        asked = self.bus.ask(keys.register(self.sim), payload, timeout_s=2.0)
        now = time.monotonic()
        self._registering[peer] = _Pending(asked, payload, now, now, spec, params, nb, nb_sensed)

    def _answer_registrations(self) -> None:
        """Finishes every registration the world has answered; one no world answered is asked
        again for WORLD_WAIT_S (a world still starting), then refused."""
        for peer, p in list(self._registering.items()):
            if not p.asked.answered():
                continue
            now = time.monotonic()
            if not p.asked.replies and now - p.since < WORLD_WAIT_S:
                if now - p.asked_at >= ASK_AGAIN_S:  # no queryable answers at once: not in a busy loop
                    p.asked, p.asked_at = self.bus.ask(keys.register(self.sim), p.payload, timeout_s=2.0), now
                continue
            del self._registering[peer]
            try:
                reply = decode(p.asked.replies[0], RegisterReply) if p.asked.replies else None
            except IwError as e:
                logger.warning("the world's registration answer does not decode: %s", e)
                reply = None
            self._registered(peer, reply, p.spec, p.params, p.nb, p.nb_sensed)

    def _registered(
        self,
        peer: tuple[str, int],
        reply: RegisterReply | None,
        spec: RobotSpec,
        params: SimParameters,
        nb: int,
        nb_sensed: int,
    ) -> None:
        """Tells a legacy robot the world's answer, from a socket of its own."""
        sock = self._new_socket()
        if reply is None or not reply.ok:
            self._refuse(peer, reply.reason if reply else "no world answered the registration")
            sock.sendto(build_refusal(), peer)
            sock.close()
            return
        c = Client("robot", peer, sock, robot_id=reply.robot_id, name=spec.name, n_beacons=nb_sensed)
        if spec.beacon_height_m is not None:
            self._carriers.add(reply.robot_id)
        placed = reply.spec
        if placed is not None and placed.x is not None and placed.y is not None:
            c.start = (placed.x, placed.y)
        self.clients[peer] = c
        self.by_robot[c.robot_id] = c
        self.sel.register(sock, selectors.EVENT_READ, c)
        self._game(c)  # its state machine and score, from its first step
        sock.sendto(build_reply(params, n_beacons=nb), peer)
        logger.info("legacy robot %s from %s:%d is robot %d", spec.name, peer[0], peer[1], c.robot_id)

    def on_client_datagram(self, c: Client, data: bytes, peer: tuple[str, int]) -> None:
        """A datagram on a client's own socket."""
        if peer != c.addr:
            self._refuse(peer, f"a datagram on the socket of {c.addr[0]}:{c.addr[1]} from another address")
            return
        if c.kind == "robot":
            try:
                a = parse_actions(data)
            except ProtocolError as e:
                self._refuse(peer, str(e))
                return
            c.requests += list(a.requests)
            c.left = a.left if a.left is not None else c.left
            c.right = a.right if a.right is not None else c.right
            c.leds.update(a.leds)
            if a.leds.get("ReturningLed"):
                c.returning_now = True
            if c.leds.get("EndLed"):
                c.finished = True
            if c.finished or self.finished_at is not None:  # a Finished robot never moves again
                c.left = c.right = 0.0
            tick = c.reading.tick if c.reading else 0
            sim_ns = c.reading.sim_time_ns if c.reading else 0
            if a.pose is not None:
                x, y, d = a.pose
                self.io.send(
                    keys.pose_report(self.sim, c.robot_id),
                    PoseReport(tick=tick, sim_time_ns=sim_ns, robot_id=c.robot_id, x=x, y=y, dir_deg=d),
                )
            if a.say is not None:
                self.io.send(
                    keys.say(self.sim, c.robot_id), Say(tick=tick, sim_time_ns=sim_ns, robot_id=c.robot_id, text=a.say)
                )
            act = Actions(
                tick=tick,
                sim_time_ns=sim_ns,
                robot_id=c.robot_id,
                left=c.left,
                right=c.right,
                end_led=c.leds.get("EndLed", False),
                returning_led=c.leds.get("ReturningLed", False),
                visiting_led=c.leds.get("VisitingLed", False),
            )
            self._outbox[c.robot_id] = act  # sent with the others of this pass, in one batch
        elif c.kind == "viewer":
            try:
                cmd = parse_viewer_command(data)
            except ProtocolError as e:
                self._refuse(peer, str(e))
                return
            info = self._world_info()
            if cmd.kind == "labreq" and info is not None:
                c.sock.sendto(lab_to_xml(lab_from_msg(info.lab), legacy=True) + b"\x00", peer)
            elif cmd.kind == "gridreq" and info is not None:
                c.sock.sendto(grid_to_xml(grid_from_msg(info.grid), legacy=True) + b"\x00", peer)
            elif cmd.kind in ("start", "stop") and self.finished_at is None:  # Finished is terminal
                self.io.send(keys.control(self.sim), Control(command="start" if cmd.kind == "start" else "pause"))
            elif cmd.kind == "remove":
                self.io.send(keys.control(self.sim), Control(command="remove", robot_id=cmd.robot_id))

    # --- Zenoh side ----------------------------------------------------------------------

    def _delayed(self, c: Client, name: str, value: Any, latency: int) -> Any:
        """The reading ``latency`` updates ago (Ciber-Rato's FIFO; "no measurement" at first)."""
        q = c.fifos.get(name)
        if q is None:
            default = NO_MEASUREMENT[name.rstrip("0123456789")]
            q = c.fifos[name] = collections.deque([default] * latency, maxlen=latency + 1)
        q.append(value)
        return q[0]

    def _measures(self, c: Client, tick: int) -> bytes:
        r = c.reading
        p = self.params
        buttons = (self.running, not self.running)
        if self.finished_at is not None:  # the simulator finished: Time frozen, both buttons Off
            tick = min(tick, self.finished_at)
            buttons = (False, False)
        if r is None:
            return bytes(build_measures(Measures(time=tick, collision=False, ir=(0.0,) * 4, buttons=buttons)))
        # requests: at most NRequestsPerCycle honoured, in order, across the cycle's datagrams
        granted = set(c.requests[: p.n_requests_per_cycle])
        c.requests = []

        def wanted(name: str, requestable: bool) -> bool:
            return not requestable or name in granted

        ir = tuple(
            float(self._delayed(c, f"ir{i}", v, p.obstacle_latency))
            if wanted(f"IRSensor{i}", p.obstacle_requestable)
            else None
            for i, v in enumerate(r.proximity_legacy[:4])
        )
        compass = self._delayed(c, "compass", float(round(r.compass_deg)), p.compass_latency)
        ground = self._delayed(c, "ground", r.ground, p.ground_latency)
        collision = self._delayed(c, "collision", r.collision, p.collision_latency)
        beacons = None
        if p.beacon_sensor and (not p.beacon_requestable or any(n.startswith("Beacon") for n in granted)):
            now = tuple(
                None if b is None else float(int(b + 0.5 if b >= 0 else b - 0.5)) for b in r.beacons_deg[: c.n_beacons]
            )
            beacons = tuple(self._delayed(c, f"beacon{i}", v, p.beacon_latency) for i, v in enumerate(now))
        m = Measures(
            time=tick,
            collision=bool(collision) if wanted("Collision", p.collision_requestable) else None,
            compass=float(compass) if p.compass_sensor and wanted("Compass", p.compass_requestable) else None,
            ground=int(ground) if wanted("Ground", p.ground_requestable) else None,
            ir=ir,
            beacons=beacons,
            gps=(round(r.gps[0] + GPS_OFFSET[0], 1), round(r.gps[1] + GPS_OFFSET[1], 1)) if p.gps else None,
            messages=tuple(c.heard),
            leds=(c.leds.get("EndLed", False), c.leds.get("ReturningLed", False), c.leds.get("VisitingLed", False)),
            buttons=buttons,
            score=self._score(c) if p.score_sensor else None,
        )
        return bytes(build_measures(m))

    def _score(self, c: Client) -> Score | None:
        g = c.game
        if g is None:
            return None
        return Score(
            g.score,
            arrival_time=g.arrival_time,
            returning_time=g.returning_time,
            collisions=g.collisions,
            collision=g.collision,
            visited_mask=g.visited_mask,
        )

    def pump_bus(self) -> None:
        """Takes new readings, hear lists, states and ticks; sends Measures and viewer states."""
        for _, data, _ in self.infos.drain()[-1:]:
            try:
                self.info = decode(data, WorldInfo)
            except IwError:
                continue
        for _, data, _ in self.verdicts.drain():
            try:
                v = decode(data, Verdict)
            except IwError:
                continue
            kinds: dict[int, tuple[bool, bool]] = {}
            for hit in v.hits:
                wall, robot = kinds.get(hit.robot_id, (False, False))
                kinds[hit.robot_id] = (wall or hit.wall >= 0, robot or hit.other >= 0)
            self._hits[v.tick] = kinds
            for old in [t for t in self._hits if t < v.tick - 20]:
                del self._hits[old]
        states: list[WorldState] = []
        for _, data, _ in self.states.drain():
            try:
                states.append(decode(data, WorldState))
            except IwError:
                continue
        for st in states:  # every step counts for the scores
            self._step_games(st)
            self._check_finished(st.tick)
        viewers = [c for c in self.clients.values() if c.kind == "viewer"]
        if states and viewers:
            self._send_robot_states(states[-1], viewers)

        newest: dict[int, list[SensorReading]] = {}
        pacer = self._pacer_now()
        now = time.time_ns()
        for key, data, _ in self.readings.drain():
            try:
                batch = decode(data, SensorBatch)
            except IwError as e:
                self.io.bad_message(key, e)
                continue
            if pacer is not None and batch.tick_wall_ns and batch.tick > self._paced_tick:
                self._paced_tick = batch.tick  # the tick's first batch tells how late it came
                pacer.observe(now - batch.tick_wall_ns)
            for r in batch.readings:
                if r.robot_id in self.by_robot:
                    newest.setdefault(r.robot_id, []).append(r)
        for rid, readings in newest.items():
            client = self.by_robot[rid]
            # a tick late is caught up; after a longer stall only the newest goes (never a burst
            # of stale Measures that a client would read one by one)
            for reading in readings[-CATCH_UP:]:
                if pacer is None or pacer.offset_ns is None:  # not paced, or nothing learned yet
                    client.reading = reading
                    self._send_measures(client, reading.tick)
                else:
                    due = self._due.setdefault(reading.tick, (pacer.due_ns(reading.tick_wall_ns), []))
                    due[1].append((client, reading))
        self._send_due(now)
        for _, data, _ in self.hears.drain():
            try:
                delivered = decode(data, RadioBatch)
            except IwError:
                continue
            for hear in delivered.hear:
                c = self.by_robot.get(hear.robot_id)
                if c is not None:
                    c.heard = [(h.sender, h.text) for h in hear.messages]
        for _, data, _ in self.ticks.drain()[-1:]:
            try:
                t = decode(data, Tick)
            except IwError:
                continue
            self.running = t.running
            if not t.running:  # stopped: Measures keep coming, as the legacy server sends them
                self._pause_games(t.tick)
                for c in list(self.by_robot.values()):
                    self._send_measures(c, t.tick, force=True)

    def _pacer_now(self) -> Pacer | None:
        """The pacer of a real-time world when pacing is on (lock-step waits for nobody's clock)."""
        info = self.info
        if not self.pace or info is None or info.mode != WorldMode.REALTIME:
            return None
        if self._pacer is None or self._pacer.period_ns != info.period_ns:
            self._pacer = Pacer(info.period_ns)
        return self._pacer

    def _send_due(self, now_ns: int) -> None:
        """Builds each tick's Measures shortly before their time and sends them all at it.

        Building a hundred takes several milliseconds, and how many varies: built first and then
        sent in one tight loop, every robot's Measures leaves at the same point of each cycle."""
        for tick in sorted(self._due):
            due, items = self._due[tick]
            if due - self._lead_ns > now_ns:
                break
            built = self._built.get(tick)
            if built is None:
                t0 = time.time_ns()
                built = self._built[tick] = []
                for c, r in items:
                    if c.robot_id in self.by_robot:
                        c.reading = r
                        data = self._next_measures(c, r.tick)
                        if data is not None:
                            built.append((c, data))
                now_ns = time.time_ns()
                self._lead_ns = max(MIN_LEAD_NS, (now_ns - t0) * 3 // 2 + MIN_LEAD_NS // 2)
            if due > now_ns:
                break  # built; the loop comes back within a millisecond to send
            del self._due[tick]
            del self._built[tick]
            for c, data in built:
                if c.robot_id in self.by_robot:
                    self._send(c, data)
            if logger.isEnabledFor(logging.DEBUG) and items:
                logger.debug(
                    "tick %d: %d Measures due %.1f ms after the tick began, sent %.1f ms after that, in %.1f ms",
                    tick,
                    len(built),
                    (due - items[0][1].tick_wall_ns) / 1e6,
                    (now_ns - due) / 1e6,
                    (time.time_ns() - now_ns) / 1e6,
                )

    def _check_finished(self, tick: int) -> None:
        """Ciber-Rato's simulator finishes when its Time reaches SimTime (SimTime > 0): in a world
        of the ciberrato profile the bridge then pauses the world for good; robots and viewers go
        on receiving every cycle with Time frozen and both buttons Off, and Start is ignored."""
        sim_time = self.params.sim_time
        info = self.info
        if self.finished_at is not None or sim_time <= 0 or tick < sim_time:
            return
        if info is None or info.profile != Profile.CIBERRATO:
            return  # a native world's length is its own (a legacy viewer may watch a long run)
        self.finished_at = sim_time
        for c in self.by_robot.values():
            c.left = c.right = 0.0
        self.io.send(keys.control(self.sim), Control(command="pause"))
        self.io.event(
            EventKind.LEGACY_FINISHED, f"Time reached SimTime {sim_time}: the simulation is finished", tick=tick
        )

    def _game(self, c: Client) -> RobotGame | None:
        """The robot's legacy game, made once the world's lab is known."""
        if c.game is None:
            info = self._world_info()
            if info is None:
                return None
            p = self.params
            lab = lab_from_msg(info.lab)
            c.game = RobotGame(
                lab,
                mode=self.scoring,
                sim_time=p.sim_time,
                wall_penalty=p.collision_wall_penalty,
                robot_penalty=p.collision_robot_penalty,
                start=c.start,
            )
        return c.game

    def _free_space(self) -> FreeSpace | None:
        """The lab's free space for D(p), built once in a thread of its own (part of a second for
        a Ciber-Rato lab, and the UDP loop must not stall); None until it is ready."""
        info = self.info
        if info is None:
            return None
        if self._space is None or self._space[0] != info.lab:
            box: list[FreeSpace] = []
            lab = lab_from_msg(info.lab)
            t = threading.Thread(target=lambda: box.append(FreeSpace(lab)), name="free-space", daemon=True)
            self._space = (info.lab, box)
            t.start()
        return self._space[1][0] if self._space[1] else None

    def _step_games(self, st: WorldState) -> None:
        """One committed step of every legacy robot's state machine and score."""
        hits = self._hits.pop(st.tick, {})
        for rid, x, y, hit in zip(st.ids, st.x, st.y, st.collided, strict=True):
            c = self.by_robot.get(rid)
            game = self._game(c) if c is not None else None
            if c is None or game is None:
                continue
            if game.path is None and self.scoring != Mode.CONTROL:
                space = self._free_space()
                if space is not None:
                    game.path = PathLength(game.lab, c.start, space=space)
            wall, robot = hits.get(rid, (hit, False))
            game.step(
                StepInput(
                    now=st.tick,
                    running=True,
                    x=x,
                    y=y,
                    collision=hit,
                    hit_wall=wall,
                    hit_robot=robot,
                    end_led=c.leds.get("EndLed", False),
                    returning_led=c.leds.get("ReturningLed", False),
                    visiting_led=c.leds.get("VisitingLed", False),
                    returning_now=c.returning_now,
                )
            )
            c.returning_now = False
            c.pose = (x, y)
            c.finished = c.finished or game.finished

    def _pause_games(self, tick: int) -> None:
        """A step of the state machines while the simulator is stopped (nothing scores)."""
        for c in self.by_robot.values():
            if c.game is not None:
                c.game.step(StepInput(now=tick, running=False, x=c.pose[0], y=c.pose[1]))

    def _send_robot_states(self, st: WorldState, viewers: list[Client]) -> None:
        names = {c.robot_id: c.name for c in self.by_robot.values()}
        specs = {s.id: s.name for s in (self.info.robots if self.info else [])}
        for rid, x, y, h, hit in zip(st.ids, st.x, st.y, st.heading, st.collided, strict=True):
            c = self.by_robot.get(rid)
            g = c.game if c is not None else None
            if g is None:  # a native robot: no legacy game, its collisions counted here
                if hit and not self._hit.get(rid, False):
                    self._collisions[rid] = self._collisions.get(rid, 0) + 1
                self._hit[rid] = hit
            data_out = build_robot_state(
                name=names.get(rid) or specs.get(rid, f"robot{rid}"),
                robot_id=rid,
                time=st.tick,
                x=x,
                y=y,
                dir_deg=math.degrees(h),
                collision=hit,
                collisions=g.collisions if g is not None else self._collisions.get(rid, 0),
                state=g.state if g is not None else ("Running" if self.running else "Stopped"),
                score=g.score if g is not None else 0,
                arrival_time=g.arrival_time if g is not None else st.tick,
                returning_time=g.returning_time if g is not None else 0,
                visited_mask=g.visited_mask if g is not None else "0" * len(self.info.lab.targets if self.info else ()),
            )
            for v in viewers:
                v.sock.sendto(data_out, v.addr)

    def _next_measures(self, c: Client, tick: int, *, force: bool = False) -> bytes | None:
        """The client's Measures of ``tick``, once a tick (unless forced); what it heard is then
        delivered."""
        if tick == c.sent_tick and not force:
            return None
        c.sent_tick = tick
        data = self._measures(c, tick)
        c.heard = []
        return data

    def _send(self, c: Client, data: bytes) -> None:
        try:
            c.sock.sendto(data, c.addr)
        except OSError as e:
            logger.warning("cannot send to %s:%d: %s", c.addr[0], c.addr[1], e)

    def _send_measures(self, c: Client, tick: int, *, force: bool = False) -> None:
        data = self._next_measures(c, tick, force=force)
        if data is not None:
            self._send(c, data)

    def serve(self) -> None:
        """Runs until stopped."""
        while not self.io.stop.is_set():
            for key, _ in self.sel.select(timeout=POLL_S):
                sock = key.fileobj
                assert isinstance(sock, socket.socket)
                for _ in range(64):  # drain this socket, then give the others their turn
                    try:
                        data, peer = sock.recvfrom(RECV_BYTES)
                    except BlockingIOError:
                        break
                    except OSError as e:
                        logger.warning("receive failed: %s", e)
                        break
                    if self._flood.over(peer, time.monotonic()):
                        self._refuse(peer, f"more than {FLOOD_PER_S} datagrams a second: dropped")
                        continue
                    if key.data is None:
                        self.on_registration(data, peer)
                    else:
                        self.on_client_datagram(key.data, data, peer)
            self.flush_actions()
            self._answer_registrations()
            self.pump_bus()

    def flush_actions(self) -> None:
        """Sends the actions that arrived in this pass, every robot's in one message."""
        if self._outbox:
            acts = list(self._outbox.values())
            self._outbox.clear()
            last = max(acts, key=lambda a: a.tick)
            self.io.send(
                keys.agent_actions(self.sim, self.name),
                ActionBatch(tick=last.tick, sim_time_ns=last.sim_time_ns, agent=self.name, actions=acts),
            )

    def close(self) -> None:
        """Closes every socket."""
        for c in self.clients.values():
            c.sock.close()
        self.reception.close()


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz bridge ciberrato``."""
    args_in = list(argv or [])
    if args_in[:1] != ["ciberrato"]:
        print("usage: iwz bridge ciberrato [options]   (iwz bridge ciberrato --help)")
        return 2 if args_in[:1] not in (["-h"], ["--help"]) else 0
    p = argparse.ArgumentParser(
        prog="iwz bridge ciberrato",
        description="Let unmodified Ciber-Rato / Intellwheels agents and viewers (XML/UDP) join a Zenoh simulation.",
        epilog=(
            "Example: iwz bridge ciberrato --param maps/ciberrato/C1-config.xml\n"
            "then start the legacy agents and viewers against UDP port 6000, unchanged."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--port", type=int, default=6000, help="registration port (default 6000: unmodified clients use it)")
    p.add_argument(
        "--bind", default="127.0.0.1", help="address to listen on (default loopback only; 0.0.0.0 to open it)"
    )
    p.add_argument("--param", help="a Ciber-Rato parameters file (what clients are told: sensors on/off, noise)")
    p.add_argument(
        "--scoring",
        type=int,
        choices=[0, 1, 2, 3],
        default=0,
        help="the legacy --scoring: 0 competitive (default), 1 control (C1), 2 mapping, 3 planning (C2-C5); "
        "scores go to viewers, and in Measures when the parameters' ScoreSensor is On",
    )
    p.add_argument(
        "--pace",
        choices=["auto", "off"],
        default="auto",
        help="real-time worlds: send every Measures of a cycle at a steady offset from the cycle's start, "
        "learned from how late readings come (auto, default: one period between Measures as the legacy "
        "server keeps it); off: send each as soon as its readings arrive",
    )
    p.add_argument("--name", default="ciberrato", help="process name (liveliness)")
    add_common_arguments(p)
    args = p.parse_args(args_in[1:])
    setup_logging(args.verbose, "bridge")
    try:
        params = load_parameters(args.param) if args.param else SimParameters()
        bus = ZenohBus(net_from_args(args))
    except (IwError, ValueError) as e:
        print(f"iwz bridge ciberrato: {e}")
        return 2
    try:
        bridge = Bridge(
            bus,
            keys.chunk(args.sim),
            bind=args.bind,
            port=args.port,
            params=params,
            name=keys.chunk(args.name),
            scoring=Mode(args.scoring),
            pace=args.pace == "auto",
        )
    except OSError as e:
        bus.close()
        print(
            f"iwz bridge ciberrato: cannot listen on {args.bind}:{args.port}: {e.strerror}; "
            "is another simulator running? Use --port"
        )
        return 2
    install_stop_signals(bridge.io.stop)
    print(f"iwz bridge ciberrato: listening on udp {args.bind}:{bridge.port} for iw/{args.sim}/", flush=True)
    try:
        bridge.serve()
    finally:
        bridge.close()
        bus.close()
    return 0
