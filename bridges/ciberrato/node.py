"""``iwz bridge ciberrato``: unmodified Ciber-Rato / Intellwheels agents and viewers join a Zenoh
simulation over the legacy XML/UDP protocol.

Each legacy client gets a socket of its own (the reply and everything after come from it, as the
legacy server does); robots become robots of the Zenoh world (registered through the world's
queryable, driven by their actions, fed Measures from the Zenoh sensor readings every tick, in
every simulator state); viewers get the reply, the lab and grid on request, and one robot state
per robot per tick. A bad datagram is answered where the protocol allows (a refusal) or dropped
with an event naming the peer and the reason; it never stalls another client.

The node is the wiring only: each robot's legacy state is a :class:`~.robot.LegacyRobot`, who may
join is the :class:`~.registrar.Registrar`'s, the games are the :class:`~.referee.Referee`'s,
when Measures go is the :class:`~.delivery.Delivery`'s, what it hears of the world the
:class:`~.feed.WorldFeed`'s; its sockets are given to it
(:mod:`.transport`), and it drives its robots through the agent host's own outgoing path.
"""

from __future__ import annotations

import dataclasses
import logging
import time

from iw_zenoh import keys
from iw_zenoh.agent.hosting import Outbox
from iw_zenoh.convert import grid_from_msg, lab_from_msg
from iw_zenoh.core.params import SimParameters
from iw_zenoh.errors import ProtocolError
from iw_zenoh.maps import grid_to_xml, lab_to_xml
from iw_zenoh.messages import (
    Control,
    EventKind,
    LegacyRefusedData,
    RadioDroppedData,
    RegisterReply,
    Say,
    SensorReading,
)
from iw_zenoh.process.runtime import NodeIO
from iw_zenoh.ticks import TickWindow

from .clients import ROBOT_QUIET_S, ClientTable
from .codec import parse_actions, parse_viewer_command
from .delivery import Delivery
from .feed import WorldFeed
from .guard import Gate, Report
from .hearing import Hearing
from .referee import Referee
from .registrar import Pending, Registrar
from .registration import build_refusal, build_reply, parse_registration
from .robot import LegacyRobot
from .scoring import Mode
from .transport import (
    DatagramTransport,
    QueueBus,
    RobotLink,
    TransportFactory,
    Viewer,
)

__all__ = ["Bridge"]

logger = logging.getLogger(__name__)

RECV_BYTES = 4096
POLL_S = 0.001  # the loop looks at the bus queues at least this often
PER_PASS = 64  # datagrams read from one socket in a pass of the loop (then the bus, Measures)
SWEEP_S = 1.0  # how often gone clients are looked for

Peer = tuple[str, int]


class Bridge:
    """The bridge's wiring: UDP on one side, the bus on the other.

    Args:
        bus: The bus.
        sim: Simulation name.
        reception: The registration socket (UDP port 6000 for unmodified clients).
        new_transport: Makes each client's own socket.
        params: The legacy parameters clients are told.
        name: Process name (its liveliness token drives the world's safety rules).
        scoring: The legacy scoring mode.
        pace: In a real-time world, send each tick's Measures at a steady offset from the tick's
            start (see :mod:`.pacing`) rather than as soon as the readings arrive.
    """

    def __init__(
        self,
        bus: QueueBus,
        sim: str,
        reception: DatagramTransport,
        *,
        new_transport: TransportFactory,
        params: SimParameters | None = None,
        name: str = "ciberrato",
        scoring: Mode = Mode.COMPETITIVE,
        pace: bool = True,
    ) -> None:
        self.bus, self.sim, self.name = bus, sim, name
        self.params = params or SimParameters()
        self.io = NodeIO(bus, sim, "agent", name)  # its robots stop if this process goes
        self.reception = reception
        self.new_transport = new_transport
        self.clients = ClientTable(reception)
        self.robots: dict[int, LegacyRobot] = {}
        self.running = True
        self.window = TickWindow()  # a tick of 10^15 would finish the game or silence a robot
        self.feed = WorldFeed(bus, sim, self.io, self.window)  # the world, from Zenoh's own queues
        self.outbox = Outbox(bus, sim, name, batched=True)  # every robot's actions of a pass in one
        self.registrar = Registrar(bus, sim, name, self.params)
        self.referee = Referee(self.params, scoring, self.feed.world_info)
        self.delivery = Delivery(pace=pace)
        self.gate = Gate(self._tell)  # the flood limits; refusals told once per address a second
        self._controls: list[Control] = []  # viewers' commands of a pass, sent after its actions
        self._swept = 0.0
        self.hearing = Hearing()  # a tick's readings wait for its hear lists (while a radio is alive)
        bus.watch_alive(keys.all_alive(sim), self._on_alive)
        self.io.alive()
        bus.token(keys.alive(sim, "bridge", name))

    # --- legacy side ---------------------------------------------------------------------

    def _refuse(self, peer: Peer, reason: str, *, dropped: bool = False) -> None:
        """Counts a refused datagram: told (log line and event) at most once per address a second."""
        self.gate.refuse(peer, reason, time.monotonic(), dropped=dropped)

    def _tell(self, rep: Report) -> None:
        """One log line and one event for an address's refusals."""
        line = rep.line(self.gate.every_s)
        logger.warning("%s", line)
        data = LegacyRefusedData(peer=f"{rep.host}:{rep.port}", count=rep.count, dropped=rep.dropped)
        self.io.event(EventKind.LEGACY_REFUSED, line, data)

    def _answer_alone(self, data: bytes, peer: Peer) -> None:
        """Answers from a socket of its own that closes at once (a refusal)."""
        t = self.new_transport()
        try:
            t.sendto(data, peer)
        except OSError as e:
            self._refuse(peer, f"cannot answer: {e}")
        finally:
            t.close()

    def on_registration(self, data: bytes, peer: Peer) -> None:
        """A datagram on the registration port."""
        known = self.clients.get(peer)
        if isinstance(known, RobotLink):
            self._refuse(peer, "a second registration from a registered address")
            self.reception.sendto(build_refusal(), peer)
            return
        try:
            reg = parse_registration(data)
        except ProtocolError as e:
            self._refuse(peer, str(e))  # the legacy server answers nothing to what does not parse
            return
        if not self._robot_place(peer, time.monotonic()):
            return
        info = self.feed.world_info()
        adm = self.registrar.admit(reg, peer, info, self.clients.by_robot, time.monotonic())
        if adm.refused:
            self._refuse(peer, adm.refused)
            if adm.answer:
                self._answer_alone(build_refusal(), peer)
        elif adm.viewer and adm.params is not None:
            self._viewer(adm.viewer, peer, build_reply(adm.params, n_beacons=adm.nb), known)

    def _robot_place(self, peer: Peer, now: float) -> bool:
        """Whether a new robot from ``peer`` may be served: room, or made by letting go the robot
        whose client has been silent longest (it is removed from the world too: nobody drives it);
        refused, answered with a refusal, when every served client spoke lately."""
        place = self.clients.robot_place(now)
        if place is False:
            served = self.clients.max_robots
            self._refuse(peer, f"{served} legacy robots are served, each heard within {ROBOT_QUIET_S:g} s")
            self._answer_alone(build_refusal(), peer)
            return False
        if isinstance(place, RobotLink):
            silent = "nothing listens for it" if place.unreachable else f"silent {now - place.heard:.0f} s"
            self._let_go(place, f"{silent}: its place is given to a new robot")
            self._controls.append(Control(command="remove", robot_id=place.robot.robot_id))
        return True

    def _viewer(self, kind: str, peer: Peer, reply: bytes, known: Viewer | None) -> None:
        """Serves a viewer or panel from a socket of its own (its own again, if it is served)."""
        if known is not None:  # asked again: answered from the socket it has, no new one
            known.transport.sendto(reply, peer)
            return
        if self.clients.full(time.monotonic()):
            self._refuse(peer, f"{self.clients.max_viewers} viewers and panels are served already")
            self.reception.sendto(build_refusal(), peer)
            return
        t = self.new_transport()
        v = Viewer("viewer" if kind == "view" else "panel", peer, t, since=time.monotonic())
        self.clients.add(v)
        t.sendto(reply, peer)

    def _registered(self, peer: Peer, p: Pending, reply: RegisterReply | None) -> None:
        """Tells a legacy robot the world's answer, from a socket of its own."""
        if reply is None or not reply.ok:
            self._refuse(peer, reply.reason if reply else "no world answered the registration")
            self._answer_alone(build_refusal(), peer)
            return
        # told what the world is now: a registration may have come before its description did
        params, nb = self.registrar.told(self.feed.world_info(now_or_never=True))
        t = self.new_transport()
        robot = LegacyRobot(reply.robot_id, name=p.spec.name, n_beacons=nb + p.carried)
        self.registrar.accepted(reply.robot_id, p.spec)
        placed = reply.spec
        if placed is not None and placed.x_m is not None and placed.y_m is not None:
            robot.start = robot.pose = (placed.x_m, placed.y_m)
        now = time.monotonic()
        link = RobotLink(peer, t, robot, seen=now, heard=now)
        self.clients.add(link)
        self.robots[robot.robot_id] = robot
        self.referee.game(robot)  # its state machine and score, from its first step
        t.sendto(build_reply(params, n_beacons=nb), peer)
        logger.info("legacy robot %s from %s:%d is robot %d", p.spec.name, peer[0], peer[1], robot.robot_id)

    def on_client_datagram(self, c: Viewer | RobotLink, data: bytes, peer: Peer) -> None:
        """A datagram on a client's own socket."""
        if peer != c.addr:
            self._refuse(peer, f"a datagram on the socket of {c.addr[0]}:{c.addr[1]} from another address")
        elif isinstance(c, RobotLink):
            c.heard = time.monotonic()
            self._on_actions(c.robot, data, peer)
        elif c.kind == "viewer":
            c.heard = True
            self._on_viewer(c, data, peer)

    def _on_actions(self, robot: LegacyRobot, data: bytes, peer: Peer) -> None:
        try:
            frame = parse_actions(data)
        except ProtocolError as e:
            self._refuse(peer, str(e))
            return
        cmd = robot.on_actions(frame, sim_finished=self.referee.finished_at is not None)
        if cmd.say is not None and not self.running:  # stopped: heard in the next stopped Measures
            self.hearing.stopped_says[robot.robot_id] = cmd.say
            cmd = dataclasses.replace(cmd, say=None)
        tick, sim_ns = robot.stamp()
        self.outbox.command(robot.robot_id, cmd, tick=tick, sim_time_ns=sim_ns)  # sent with the pass's

    def _on_viewer(self, v: Viewer, data: bytes, peer: Peer) -> None:
        try:
            cmd = parse_viewer_command(data)
        except ProtocolError as e:
            self._refuse(peer, str(e))
            return
        info = self.feed.world_info()
        if cmd.kind == "labreq" and info is not None:
            v.transport.sendto(lab_to_xml(lab_from_msg(info.lab), legacy=True) + b"\x00", peer)
        elif cmd.kind == "gridreq" and info is not None:
            v.transport.sendto(grid_to_xml(grid_from_msg(info.grid), legacy=True) + b"\x00", peer)
        elif cmd.kind in ("start", "stop") and self.referee.finished_at is None:  # Finished is terminal
            self._controls.append(Control(command="start" if cmd.kind == "start" else "pause"))
        elif cmd.kind == "remove":
            self._controls.append(Control(command="remove", robot_id=cmd.robot_id))

    # --- Zenoh side ----------------------------------------------------------------------

    def pump_bus(self) -> None:
        """Takes new readings, hear lists, states and ticks; sends Measures and viewer states."""
        self.feed.take_info()
        for verdict in self.feed.verdicts():
            self.referee.on_verdict(verdict)
        self._take_states()
        self.hearing.take(self.feed.radio(), self.robots)  # before the readings: Measures carry their tick's
        self._take_readings()
        self._take_ticks()
        missed, why = self.hearing.missed(self.robots, time.monotonic())
        if why:
            logger.warning("%s", why)
            self.io.event(EventKind.RADIO_DROPPED, why, RadioDroppedData(late=missed))

    def _take_states(self) -> None:
        states = self.feed.states()
        for st in states:  # every step counts for the scores
            self.referee.step(st, self.robots, self.feed.info)
            self._check_finished(st.tick)
        if states:
            for link in self.clients.gone_robots(set(states[-1].ids), time.monotonic()):
                self._let_go(link, "the world no longer holds it")
        viewers = self.clients.viewers("viewer")
        if states and viewers:
            for data in self.referee.robot_states(states[-1], self.robots, self.feed.info, running=self.running):
                for v in viewers:
                    self.clients.send(v, data)

    def _take_readings(self) -> None:
        batches = self.hearing.ready(self.feed.sensor_batches(), self.feed.info, time.monotonic_ns())
        now = time.time_ns()
        for robot, reading in self.delivery.arrived(batches, self.robots, self.feed.info, now):
            robot.reading = reading
            self._send_measures(robot, reading.tick)
        self.delivery.send_due(now, self._build, self._send_to, time.time_ns)

    def _build(self, robot: LegacyRobot, reading: SensorReading) -> bytes | None:
        robot.reading = reading
        return self._next_measures(robot, reading.tick)

    def _take_ticks(self) -> None:
        for t in self.feed.ticks()[-1:]:
            self.running = t.running
            if t.running:  # said as the run started: the radio delivers them with the next tick
                says, self.hearing.stopped_says = self.hearing.stopped_says, {}
                for rid, text in says.items():
                    say = Say(tick=t.tick, sim_time_ns=t.sim_time_ns, robot_id=rid, text=text)
                    self.io.send(keys.say(self.sim, rid), say)
            else:  # stopped: Measures keep coming, as the legacy server sends them, with the says
                self.hearing.stopped(t.tick, self.robots)
                for robot in self.robots.values():
                    robot.pause(t.tick)
                for robot in list(self.robots.values()):
                    self._send_measures(robot, t.tick, force=True)

    def _on_alive(self, key: str, alive: bool) -> None:
        """A liveliness token came or went: the radios' are kept (a set changed in one call)."""
        parts = keys.alive_parts(key)
        if parts is not None and parts[0] == "radio":
            self.hearing.on_alive(parts[1], alive)

    def _check_finished(self, tick: int) -> None:
        """At SimTime the legacy simulation finishes: the world is paused for good."""
        if self.referee.finish(tick, self.feed.info, self.robots):
            sim_time = self.params.sim_time
            self.io.send(keys.control(self.sim), Control(command="pause"))
            self.io.event(
                EventKind.LEGACY_FINISHED, f"Time reached SimTime {sim_time}: the simulation is finished", tick=tick
            )

    def _next_measures(self, robot: LegacyRobot, tick: int, *, force: bool = False) -> bytes | None:
        """The robot's Measures of ``tick``, once a tick (unless forced)."""
        return robot.next_measures(
            tick, self.params, running=self.running, finished_at=self.referee.finished_at, force=force
        )

    def _send_to(self, robot: LegacyRobot, data: bytes) -> None:
        link = self.clients.by_robot.get(robot.robot_id)
        if link is not None:
            self.clients.send(link, data)

    def _let_go(self, link: RobotLink, why: str) -> None:
        """Closes a robot's socket and forgets it."""
        self.clients.drop(link)
        self.robots.pop(link.robot.robot_id, None)
        logger.info("legacy robot %d at %s:%d let go: %s", link.robot.robot_id, link.addr[0], link.addr[1], why)

    def _sweep(self, now: float) -> None:
        """The refusals due; once a second, the silent viewers let go."""
        self.gate.due(now)
        if now - self._swept >= SWEEP_S:
            self._swept = now
            self.clients.expire(now)

    def _send_measures(self, robot: LegacyRobot, tick: int, *, force: bool = False) -> None:
        data = self._next_measures(robot, tick, force=force)
        if data is not None:
            self._send_to(robot, data)

    # --- the loop ------------------------------------------------------------------------

    def _drain(self, transport: DatagramTransport, client: Viewer | RobotLink | None) -> None:
        """Reads a socket's waiting datagrams (at most PER_PASS: then the bus and the other
        sockets get their turn). A datagram over its source's budget (its address on the
        registration port, its client on a client's socket) is dropped unread."""
        now = time.monotonic()
        for _ in range(PER_PASS):
            try:
                data, peer = transport.recvfrom(RECV_BYTES)
            except BlockingIOError:
                break
            except ConnectionRefusedError:
                if client is not None:
                    self.clients.unreachable(client)
                break
            except OSError as e:
                self._refuse(client.addr if client else ("?", 0), f"receive failed: {e}")
                break
            if not self.gate.let_in(peer, client.addr if client else None, now):
                until = self.gate.resumes_at(client.addr if client else None, now)
                if until is not None:  # its budget is spent: not read again until it has one
                    self.clients.mute(transport, client, until)
                    break
                continue
            try:
                if client is None:
                    self.on_registration(data, peer)
                else:
                    self.on_client_datagram(client, data, peer)
            except OSError as e:  # no socket left for a client, a full send buffer: refused, not fatal
                self._refuse(peer, f"cannot serve it: {e}")

    def poll(self, timeout_s: float = POLL_S) -> None:
        """One pass: the sockets' datagrams, the pass's actions, answered registrations, the bus."""
        self.clients.unmute(time.monotonic())
        for transport, client in self.clients.ready(timeout_s):
            if client is None or self.clients.get(client.addr) is client:  # not let go in this pass
                self._drain(transport, client)
        self.outbox.flush()
        for control in self._controls:  # after the pass's actions: a Start never overtakes them
            self.io.send(keys.control(self.sim), control)
        self._controls.clear()
        for peer, pending, reply in self.registrar.answered(time.monotonic()):
            try:
                self._registered(peer, pending, reply)
            except OSError as e:  # no socket left for it: refused, the others go on
                self._refuse(peer, f"cannot serve it: {e}")
        self.pump_bus()
        self._sweep(time.monotonic())

    def serve(self) -> None:
        """Runs until stopped."""
        while not self.io.stop.is_set():
            self.poll()

    def close(self) -> None:
        """Closes every socket."""
        self.clients.close()
        self.reception.close()
