"""``iwz ros2``: chairs a ROS 2 stack drives, on rmw_zenoh's keys (docs/ros2.md).

The process is its chairs' agent (it registers them, as ``iwz agent`` does, or the launcher starts
it for a scenario's ``[[agents]]`` entry whose program is ``ros2``). For each chair, in its
namespace (``/robot{id}`` by default), it publishes ``odom`` (from the world's state of each tick),
``scan`` per laser and ``range/{sensor}`` per proximity cone (from the readings of each tick), and
for all its chairs ``/tf`` and ``/clock`` (the simulation's time: ``use_sim_time``); it subscribes
``cmd_vel`` (Twist, or TwistStamped with ``--stamped``) and drives the chair with it through the
chair's own motor model. Each tick it answers with the newest command; one older than 0.5 s (of
simulated or of wall time) stops the chair. A sample that does not decode is refused, counted and
reported as a bad-message event; the process goes on.
"""

from __future__ import annotations

import argparse
import collections
import logging
import os
import threading
import time
from collections.abc import Sequence
from types import SimpleNamespace
from typing import Any

from iw_zenoh import keys
from iw_zenoh.agent import AgentHost, RegistrationRefused
from iw_zenoh.agent.hosting import Command
from iw_zenoh.agent.programs import add_spec_arguments, make_with_spec
from iw_zenoh.bus import Bus
from iw_zenoh.core.motor import powers_for_twist
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.errors import DecodeError, IwError
from iw_zenoh.messages import Heard, SensorReading, WorldInfo, WorldState
from iw_zenoh.nodes.ros2_link import Ros2Link, Ros2Publisher, Sample
from iw_zenoh.process.runtime import NodeIO, Process, start_role
from iw_zenoh.ros2 import convert, graph
from iw_zenoh.ros2 import types as t
from iw_zenoh.ros2.chair import CLOCK_TOPIC, TF_TOPIC, ChairTopics, namespace_of

__all__ = ["CMD_TIMEOUT_S", "Ros2Chair", "main"]

logger = logging.getLogger(__name__)

CMD_TIMEOUT_S = 0.5  # ros2_controllers' diff_drive_controller cmd_vel_timeout
INFO_ASKS = 3  # the world asked for its description at most this often while replies do not decode
STATE_POLL_S = 0.2  # the state thread looks whether it is to stop at least this often
COMMANDS_KEPT = 64  # cmd_vel samples waiting for the next tick (only the newest valid one counts)
NODE_NAME = "iwz_chair"
SENSOR_QOS, ODOM_QOS, TF_QOS, CLOCK_QOS = (
    graph.Qos(depth=5),
    graph.Qos(depth=10),
    graph.Qos(depth=100),
    graph.Qos(depth=1),
)


class Ros2Chair:
    """One chair a ROS 2 stack drives (an :class:`~iw_zenoh.agent.Agent`).

    Args:
        name: The robot's name.
        robot_id: The id to ask for (0: the world's choice).
        namespace: The namespace template, ``{id}`` the robot's id.
        stamped: cmd_vel is a TwistStamped.
    """

    def __init__(self, name: str, robot_id: int, namespace: str, stamped: bool) -> None:
        self.name, self.robot_id, self.template, self.stamped = name, robot_id, namespace, stamped
        self.commands: collections.deque[tuple[Sample, float]] = collections.deque(maxlen=COMMANDS_KEPT)
        self.accepted = self.refused = 0
        self.command: tuple[float, float] = (0.0, 0.0)
        self.command_wall = self.command_sim = -1.0  # when the command in force came (s): none yet
        self.topics: ChairTopics | None = None
        self.odom: Ros2Publisher | None = None
        self.scans: dict[int, Ros2Publisher] = {}
        self.ranges: dict[int, Ros2Publisher] = {}
        self.cmd_key = ""
        self.on_bad: Any = None  # the host's report of a refused sample (key, error)
        self.clock = time.monotonic

    def spec(self) -> RobotSpec:
        return RobotSpec(self.name, id=self.robot_id)

    def on_registered(self, robot_id: int, spec: RobotSpec) -> None:
        self.robot_id = robot_id
        self.topics = ChairTopics(robot_id, namespace_of(self.template, robot_id), spec)

    def declare(self, link: Ros2Link) -> None:
        """Declares this chair's ROS 2 node, publishers and subscription."""
        tp = self.topics
        assert tp is not None
        node = link.node(tp.namespace, NODE_NAME)
        self.odom = node.publisher(tp.odom_topic(), t.ODOMETRY, ODOM_QOS)
        for laser in tp.spec.lasers:
            self.scans[laser.id] = node.publisher(tp.scan_topic(laser.id), t.LASER_SCAN, SENSOR_QOS)
        for ir in tp.spec.ir_sensors:
            self.ranges[ir.id] = node.publisher(tp.range_topic(ir.id), t.RANGE, SENSOR_QOS)
        kind = t.TWIST_STAMPED if self.stamped else t.TWIST
        self.cmd_key = node.subscription(tp.cmd_vel_topic(), kind, ODOM_QOS, self._on_cmd)

    def _on_cmd(self, sample: Sample) -> None:
        """Keeps a cmd_vel sample for the next tick (on Zenoh's thread: no parsing here)."""
        self.commands.append((sample, self.clock()))

    def _take_commands(self, sim_s: float) -> None:
        """The newest valid command becomes the one in force; each bad one is refused and reported."""
        while self.commands:
            (payload, att), at = self.commands.popleft()
            try:
                if att is not None:
                    graph.Attachment.decode(att)
                v_w = convert.twist_of(payload, stamped=self.stamped)
            except DecodeError as e:
                self.refused += 1
                if self.on_bad is not None:
                    self.on_bad(self.cmd_key, e)
                continue
            self.accepted += 1
            self.command, self.command_wall, self.command_sim = v_w, at, sim_s

    def on_sensors(self, reading: SensorReading, heard: list[Heard]) -> Command:
        """Publishes the tick's scans and ranges, then answers with the newest command."""
        tp = self.topics
        assert tp is not None
        for lid, data in tp.scans(reading):
            if lid in self.scans:
                self.scans[lid].put(data)
        for sid, data in tp.ranges(reading):
            if sid in self.ranges:
                self.ranges[sid].put(data)
        sim_s = reading.sim_time_ns / 1e9
        self._take_commands(sim_s)
        age_wall, age_sim = self.clock() - self.command_wall, sim_s - self.command_sim
        if self.command_wall < 0 or age_wall > CMD_TIMEOUT_S or age_sim > CMD_TIMEOUT_S:
            return Command(0.0, 0.0)  # no command, or a stale one: the chair stops
        left, right = powers_for_twist(*self.command, tp.spec.max_speed_mps, tp.spec.height_m)
        return Command(left, right)


class StateToRos:
    """Publishes odom per chair, and /tf and /clock, from each world state: Zenoh's thread only
    puts the state in a newest-only inbox; this role's own thread decodes it and publishes (a
    consumer never does slow work in a Zenoh callback: 600 transforms a tick at 100 chairs)."""

    def __init__(self, link: Ros2Link, chairs: dict[int, Ros2Chair], period_s: float, io: NodeIO) -> None:
        root = link.node("/", "iwz_sim")
        self.tf = root.publisher(TF_TOPIC, t.TF_MESSAGE, TF_QOS)
        self.clock = root.publisher(CLOCK_TOPIC, t.CLOCK, CLOCK_QOS)
        self.chairs, self.period_s, self.io = chairs, period_s, io
        self.published = 0
        self.wake, self.done = threading.Event(), threading.Event()
        self.box = io.inbox(keys.state(io.sim), wake=self.wake)  # superseded: the newest few kept
        self.thread = threading.Thread(target=self._loop, name="ros2-state", daemon=True)
        self.thread.start()

    def close(self) -> None:
        """Stops the publishing thread (after what it is publishing now)."""
        self.done.set()
        self.wake.set()
        self.thread.join()

    def _loop(self) -> None:
        while not self.done.is_set():
            self.wake.wait(STATE_POLL_S)
            self.wake.clear()
            for delivery in self.box.drain():
                st = self.io.decode(delivery, WorldState)  # a bad one refused with its reason
                if st is not None:
                    self._publish(st)

    def _publish(self, st: WorldState) -> None:
        links: list[tuple[str, str, float, float, float]] = []
        for i, rid in enumerate(st.ids):
            chair = self.chairs.get(rid)
            if chair is None or chair.odom is None or chair.topics is None:
                continue
            chair.odom.put(chair.topics.odom(st, i, self.period_s))
            links += chair.topics.links(st, i)
        if links:
            self.tf.put(convert.tf_message(st.sim_time_ns, links))
        self.clock.put(convert.clock(st.sim_time_ns))
        self.published += 1


def tick_period_s(bus: Bus, io: NodeIO, asks: int = INFO_ASKS, timeout_s: float = 5.0) -> float:
    """The world's tick period from its description (``world/info``); a reply that does not decode
    (a forger's, a damaged one) is refused with its reason and the world asked again; 0.1 s when
    no description comes."""
    key = keys.info(io.sim)
    for _ in range(asks):
        replies = bus.query(key, timeout_s=timeout_s)
        for data in replies:
            info = io.decode((key, data, 0), WorldInfo)
            if info is not None:
                return info.period_ns / 1e9
        if not replies:
            break  # nobody answers: asking again would only wait longer
    return 0.1


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--robots", type=int, default=1, help="how many chairs to register (default 1)")
    p.add_argument("--id", type=int, default=0, help="the first chair's id (the others follow); 0: the world's choice")
    p.add_argument("--robot-name", default="ros2", help="the chairs' names (a number is added past the first)")
    p.add_argument("--domain", type=int, default=None, help="ROS_DOMAIN_ID (default: $ROS_DOMAIN_ID, else 0), 0..232")
    p.add_argument(
        "--namespace", default="/robot{id}", help="each chair's namespace; {id} is its id (default /robot{id})"
    )
    p.add_argument("--stamped", action="store_true", help="cmd_vel is geometry_msgs/TwistStamped (default Twist)")
    add_spec_arguments(p)


def _prepare(args: argparse.Namespace) -> list[Any]:
    if not 1 <= args.robots <= 1000:
        raise ValueError(f"--robots must be in 1..1000, got {args.robots}")
    domain = args.domain if args.domain is not None else int(os.environ.get("ROS_DOMAIN_ID", "0") or 0)
    args.domain = domain
    keys.ros2_everything(domain)  # refuses a bad domain here, with the reason
    if "{id}" not in args.namespace and args.robots > 1:
        raise ValueError("--namespace must hold {id} for more than one chair (each chair its own namespace)")
    first = args.id

    def make(a: argparse.Namespace) -> list[Ros2Chair]:
        return [
            Ros2Chair(
                a.robot_name if i == 0 else f"{a.robot_name}{i + 1}", first + i if first else 0, a.namespace, a.stamped
            )
            for i in range(a.robots)
        ]

    return make_with_spec(SimpleNamespace(make=make), args)  # type: ignore[arg-type]


def _run(proc: Process, agents: list[Any]) -> int:
    host = AgentHost(proc.bus, proc.sim, keys.chunk(proc.name), io=proc.io)
    link = Ros2Link(proc.bus.session, proc.args.domain)
    chairs: dict[int, Ros2Chair] = {}
    try:
        for a in agents:
            rid = host.add(a)  # calls on_registered: the id, the accepted spec, the namespace
            chair: Ros2Chair = getattr(a, "_agent", a)  # a chair under a --spec wrapper
            chair.on_bad = proc.io.bad_message
            chair.declare(link)
            chairs[rid] = chair
            logger.info("chair %d on ROS 2 domain %d as %s", rid, link.domain, chair.template.format(id=rid))
        state = StateToRos(link, chairs, tick_period_s(proc.bus, proc.io), proc.io)
        try:
            host.run()
        finally:
            state.close()
    except RegistrationRefused as e:
        print(f"{proc.prog}: registration refused: {e}", flush=True)
        return 3
    except IwError as e:
        print(f"{proc.prog}: {e}", flush=True)
        return 2
    finally:
        link.close()
    refused = sum(c.refused for c in chairs.values())
    logger.info("cmd_vel: %d taken, %d refused", sum(c.accepted for c in chairs.values()), refused)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz ros2``."""
    return start_role(
        argv,
        role="agent",
        prog="iwz ros2",
        description=(
            "Chairs a ROS 2 stack drives: each chair's odom, scan, range/s{id}, /tf and /clock on rmw_zenoh's "
            "keys, and its cmd_vel driving it (a command older than 0.5 s stops it). Run a ROS 2 Jazzy "
            "node with RMW_IMPLEMENTATION=rmw_zenoh_cpp and a Zenoh config that connects to our router."
        ),
        epilog=(
            "Examples:\n"
            "  iwz ros2 --id 1 --spec maps/chair.toml        a chair at /robot1 (odom, scan, cmd_vel...)\n"
            "  iwz ros2 --robots 3 --domain 5 --stamped      three chairs on domain 5, cmd_vel TwistStamped\n"
            "  iwz run ros2-demo                   the demo scenario, waiting for cmd_vel\n"
            "  docs/ros2.md                                  ros2 topic echo, teleop, Nav2 with use_sim_time"
        ),
        arguments=_arguments,
        prepare=_prepare,
        run=_run,
        name=lambda _args: f"ros2-{os.getpid()}",
        name_help="ros2-PID",
    )
