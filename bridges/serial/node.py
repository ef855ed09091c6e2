"""``iwz bridge serial --port DEV --robot NAME``: a real chair on RS-232 joins the simulation.

One process: registers the chair as a Real robot (through :class:`~iw_zenoh.agent.AgentHost`),
answers every tick with the pose its odometry makes of the encoder counts (the world places the
body there and computes its virtual sensors), publishes the chair's own readings on
``robot/{id}/chair`` (the augmented wheelchair merges them with the virtual ones) and sends the
actions an agent publishes for the robot to the chair. Safety rules: :mod:`.bridge` and
``docs/serial.md``. ``--log FILE`` writes a CSV of every Status (``iwz calibrate`` reads it).
"""

from __future__ import annotations

import argparse
import logging
import os
import threading
import time
from collections.abc import Sequence
from dataclasses import replace
from typing import TextIO

from iw_zenoh import keys
from iw_zenoh.agent import AgentHost, Command, RegistrationRefused
from iw_zenoh.bus import Bus, Inbox
from iw_zenoh.core.spec import NoiseSpec, RobotSpec, SensorNoise
from iw_zenoh.messages import Actions, ChairReading, Control, EventKind, Heard, SensorReading, SerialLinkData
from iw_zenoh.process.runtime import Process, start_role

from .board import chair_spec
from .bridge import BridgeCore, WheelOdometry, ranges_m, watchdog, wheels
from .line import Line, LinkLost, SerialLine
from .protocol import FrameDecoder, Message, Status, encode_frame

__all__ = ["CSV_HEADER", "SerialBridge", "main"]

logger = logging.getLogger(__name__)

SEND_PERIOD_S = 0.05  # a command (or zero, or EStop) goes out at least this often
POLL_S = 0.005  # the longest an action waits before it goes out
RETRY_S = 0.1  # how often a lost device is looked for again
DOWN_REPORT_S = 0.2  # while the link is down, a 'down' reading this often
IDLE_REPORT_S = 1.0  # no tick (a paused world, none yet): a reading this often; else one a tick
_EXACT = NoiseSpec(0.0, 0.0, enabled=False)
# the virtual sensors of a Real robot as an in-process augmented chair registers them, but an exact
# GPS: it reads back the pose the bridge reported, where the world took the virtual readings
VIRTUAL_NOISE = SensorNoise(gps_m=_EXACT, gps_heading_deg=_EXACT)
CSV_HEADER = "t,left_ticks,right_ticks,left_cmd,right_cmd,left_wheel,right_wheel,battery_v,flags\n"


class _Chair:
    """The bridge's robot as the agent host sees it: answers each tick with the odometry pose."""

    def __init__(self, bridge: SerialBridge) -> None:
        self.bridge = bridge

    def spec(self) -> RobotSpec:
        """The chair, a Real robot."""
        return self.bridge.spec

    def on_registered(self, robot_id: int, spec: RobotSpec) -> None:
        """The world's id for the chair: at its registration, and at each one anew (a chair the
        world removed is registered again by the host, and with no id asked it may get another)."""
        self.bridge.take_id(robot_id)

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """The odometry pose, no actions (the chair's agent commands it)."""
        with self.bridge.lock:
            pose = self.bridge.core.odometry.pose
        self.bridge.ticked = True  # the serial loop publishes the chair's newest reading once for it
        return Command(pose=pose, actions=False)


class SerialBridge:
    """A chair on a serial line, on the bus.

    Args:
        bus: The bus.
        sim: Simulation name.
        name: Process name (liveliness).
        port: Device path or pyserial URL.
        spec: The chair (start pose set).
        baud: Bits a second.
        log: CSV log of every Status, or None.
    """

    def __init__(
        self,
        bus: Bus,
        sim: str,
        name: str,
        *,
        port: str,
        spec: RobotSpec,
        baud: int = 115200,
        log: TextIO | None = None,
    ) -> None:
        self.host = AgentHost(bus, sim, name)
        self.sim, self.port, self.baud, self.spec, self.log = sim, port, baud, spec, log
        start = (spec.x_m or 0.0, spec.y_m or 0.0, spec.dir_deg or 0.0)
        odometry = WheelOdometry(start, spec.wheel_base_m, spec.encoder.ticks_per_m)
        self.core = BridgeCore(odometry, spec.max_speed_mps)
        self.lock = threading.Lock()
        self.robot_id = 0
        self.line: Line | None = None
        self.decoder = FrameDecoder()
        self.seq = 0
        self._was_up = False
        self._told_no_device = False  # said once that the device cannot be opened (until it is)
        self._down_sent = -1e9
        self._published = -1e9  # when the last chair reading went out
        self.ticked = False  # a tick came since (the agent host's thread sets it)
        self._last_sent: Message | None = None
        self.actions: Inbox | None = None  # before asking for the chair's id (once it is known, for 0)
        self._actions_id = 0  # the robot whose actions self.actions hears
        self._old_actions: list[Inbox] = []  # those of an id the chair had before: emptied, never obeyed
        # an operator's e-stop may come the moment anything of the chair shows (its link event
        # comes before its registration): the control key is heard from the start
        self.control: Inbox = self.host.io.inbox(keys.control(sim))
        if log is not None:
            log.write(CSV_HEADER)

    def register(self) -> int:
        """Registers the chair; returns its robot id.

        Its inboxes exist before anything of it shows: the control key's from the start, its
        actions' before the world is asked when the id is asked for (the world's ``registered``
        event and the chair's agent may come before the answer). The serial loop (another
        thread) publishes the chair's readings once ``robot_id`` is set, so it is set last: an
        operator who sees the first reading and presses e-stop at once finds it heard.
        """
        if self.spec.id > 0:  # the world gives the id asked for
            self._hear_actions(self.spec.id)
        rid = self.host.add(_Chair(self))
        self.take_id(rid)  # (as on_registered did, for a host that calls it)
        return rid

    def take_id(self, rid: int) -> None:
        """Makes ``rid`` the chair's robot id: its actions heard first, then the id set (the
        serial loop publishes the chair's readings, and obeys controls, for the id set)."""
        self._hear_actions(rid)
        self.robot_id = rid

    def _hear_actions(self, rid: int) -> None:
        if rid != self._actions_id:
            if self.actions is not None:
                self._old_actions.append(self.actions)
            self.actions = self.host.io.inbox(keys.actions(self.sim, rid))
            self._actions_id = rid

    def _inputs(self, now: float) -> None:
        io = self.host.io
        if not self.robot_id or self.actions is None:
            return  # not registered yet: the chair is held at zero (what came waits in the inboxes)
        for old in self._old_actions:  # a former id's: another robot's now, or nobody's
            old.drain()
        for d in self.actions.drain():
            a = io.decode(d, Actions)
            if a is not None and a.robot_id == self.robot_id:
                self.core.on_action(a.left, a.right, now)
        for d in self.control.drain():
            c = io.decode(d, Control)
            if c is not None and c.robot_id == self.robot_id and c.command in ("estop", "clear"):
                (self.core.on_estop if c.command == "estop" else self.core.on_clear)()
                kind = EventKind.SERIAL_ESTOP if c.command == "estop" else EventKind.SERIAL_CLEAR
                io.event(kind, f"robot {self.robot_id}: operator {c.command}", robot_id=self.robot_id)

    def _open(self, now: float) -> None:
        try:
            self.line = SerialLine(self.port, self.baud)
        except LinkLost as e:
            if not self._told_no_device:  # a wrong --port or a chair not plugged in: say so, once
                self._told_no_device = True
                logger.warning(
                    "%s; trying again every %g s: is the chair plugged in, and is --port its device?", e, RETRY_S
                )
            else:
                logger.debug("no device: %s", e)
            self.host.io.stop.wait(RETRY_S)
            return
        self._told_no_device = False
        self.decoder = FrameDecoder()
        with self.lock:
            self.core.on_line(True)
        logger.info("opened %s", self.port)

    def _lost(self, why: str) -> None:
        if self.line is not None:
            self.line.close()
            self.line = None
        with self.lock:
            self.core.on_line(False)
        logger.warning("link lost: %s", why)

    def _on_status(self, st: Status, now: float) -> None:
        with self.lock:
            what, why = self.core.on_status(st, now)
        if what:  # a value the chair cannot have sent: refused (one event per reason a second)
            rid = self.robot_id
            held = " (the chair is held until a plausible one comes)" if self.core.held(now) else ""
            text = f"robot {rid}: a board Status refused: {why}{held}"
            self.host.io.refuse(what, text, key=keys.chair(self.sim, rid), robot_id=rid)
            return
        if self.log is not None:
            cmd = self.core.command if self.core.fresh(now) else (0.0, 0.0)
            lw, rw = wheels(st)
            self.log.write(
                f"{now:.4f},{st.encoders[0]},{st.encoders[1]},{cmd[0]:.4f},{cmd[1]:.4f},"
                f"{lw:.4f},{rw:.4f},{st.battery_mv / 1000:.3f},{st.flags}\n"
            )
        if self.ticked or now - self._published >= IDLE_REPORT_S:  # at most one reading a tick
            self._publish(now)

    def _publish(self, now: float) -> None:
        if (
            not self.robot_id
        ):  # not registered yet: no robot's key to report on (a secured router grants only its chair's)
            return
        self.ticked, self._published = False, now
        snap = self.core.snapshot(now)
        st = snap.status
        ids, dists = ranges_m(st) if st is not None else ([], [])
        stats = self.decoder.stats
        self.host.io.send(
            keys.chair(self.sim, self.robot_id),
            ChairReading(
                robot_id=self.robot_id,
                link="up" if snap.link_up else "down",
                pose=snap.pose,
                encoders=st.encoders if st else (0, 0),
                wheels=wheels(st) if st else (0.0, 0.0),
                proximity_ids=ids,
                proximity_m=dists,
                bumpers=[bool(st.bumpers & 1 << i) for i in range(8)] if st else [],
                battery_v=st.battery_mv / 1000 if st else 0.0,
                estop=snap.estop,
                estop_source="chair" if snap.estop_source == "chair" else "computer" if snap.estop else "",
                watchdog=watchdog(st) if st else False,
                fault=st.fault if st else 0,
                frames=stats.frames,
                dropped=stats.dropped_total,
                sent=self.seq,
            ),
        )

    def _link_events(self, now: float) -> None:
        up = self.core.link_up(now)
        if up != self._was_up:
            self._was_up = up
            kind = EventKind.SERIAL_LINK if up else EventKind.SERIAL_LINK_LOST
            why = f"robot {self.robot_id}: {'chair heard on' if up else 'nothing heard from the chair on'} {self.port}"
            self.host.io.event(kind, why, SerialLinkData(port=self.port), robot_id=self.robot_id)
        if not up and now - self._down_sent >= DOWN_REPORT_S:
            self._down_sent = now
            self._publish(now)
        self.host.io.flush_refusals()

    def serial_step(self, next_send: float) -> float:
        """One pass of the serial loop; returns when to send next."""
        now = time.monotonic()
        self._inputs(now)
        if self.line is None:
            self._open(now)
            self._link_events(time.monotonic())
            return time.monotonic()
        try:
            data = self.line.read(min(POLL_S, max(0.0, next_send - now)))
            now = time.monotonic()
            for f in self.decoder.feed(data):
                if isinstance(f.msg, Status):
                    self._on_status(f.msg, now)
            self._inputs(now)
            with self.lock:
                msg = self.core.outgoing(now)
            if now >= next_send or msg != self._last_sent:  # a change goes out at once
                self.line.write(encode_frame(msg, self.seq))
                self.seq += 1
                self._last_sent = msg
                next_send = now + SEND_PERIOD_S
        except LinkLost as e:
            self._lost(str(e))
        self._link_events(time.monotonic())
        return next_send

    def run_serial(self) -> None:
        """The serial loop, until stopped (run it in a thread)."""
        next_send = time.monotonic()
        while not self.host.io.stop.is_set():
            next_send = self.serial_step(next_send)
        if self.line is not None:
            self.line.close()


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--port", required=True, help="the chair's serial device or a pyserial URL")
    p.add_argument("--robot", required=True, help="the chair's robot name")
    p.add_argument("--baud", type=int, default=115200, help="bits a second (default 115200)")
    p.add_argument(
        "--spec", default="", help="a spec file: its [chair] table sets any registration field (docs/spec.md)"
    )
    p.add_argument("--start", default="1,1,0", help="where the chair starts: x,y,dir_deg (its odometry's origin)")
    p.add_argument("--id", type=int, default=0, help="robot id to ask for")
    p.add_argument("--log", default="", help="CSV of every board status (iwz calibrate reads it)")


def _spec(a: argparse.Namespace) -> RobotSpec:
    x, y, d = (float(v) for v in a.start.split(","))
    return replace(chair_spec(a.robot, path=a.spec, start=(x, y, d)), id=a.id, noise=VIRTUAL_NOISE)


def _run(proc: Process, spec: RobotSpec) -> int:
    a = proc.args
    log = open(a.log, "a", buffering=1) if a.log else None  # noqa: SIM115 (open for the whole run)
    bridge = SerialBridge(proc.bus, proc.sim, proc.name, port=a.port, spec=spec, baud=a.baud, log=log)
    proc.on_stop(bridge.host.io.stop.set)
    proc.on_stop(bridge.host.io.wake.set)
    serial_thread = threading.Thread(target=bridge.run_serial, name="serial", daemon=True)
    serial_thread.start()  # the chair is held at zero while the world is looked for
    try:
        rid = bridge.register()
        print(f"chair {a.robot!r} is robot {rid}, on {a.port}", flush=True)
        bridge.host.run()
    except RegistrationRefused as e:
        print(f"iwz bridge serial: registration refused: {e}")
        return 3
    finally:
        bridge.host.io.stop.set()
        serial_thread.join(2)
        if log is not None:
            log.close()
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz bridge serial``."""
    args = list(argv or [])
    if args[:1] == ["serial"]:
        args = args[1:]
    return start_role(
        args,
        role="bridge",
        prog="iwz bridge serial",
        description=(__doc__ or "").strip().splitlines()[0],
        epilog=(
            "Examples:\n"
            "  iwz bridge serial --port /dev/ttyUSB0 --robot chair --id 1 --start 10,6.1,0\n"
            "  maps/scenarios/slalom-serial.toml   the [chair] table, at work in a scenario\n"
            "  docs/serial.md            the protocol, the safety rules, the emulator"
        ),
        arguments=_arguments,
        prepare=_spec,
        run=_run,
        name=lambda _args: f"serial-{os.getpid()}",
        name_help="serial-PID",
    )
