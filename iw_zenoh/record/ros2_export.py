"""``iwz export --ros2 RUN.mcap -o DIR``: a recording as a rosbag2 bag that ROS 2 tools read
(``ros2 bag``, Foxglove, rosbags): MCAP storage, CDR messages, ``ros2msg`` schemas and
``metadata.yaml``, written by rosbags' rosbag2 writer.

The bag holds what ``iwz ros2`` publishes live, for every chair of the recording: ``odom`` and
``/tf`` and ``/clock`` from each world state, ``scan`` per laser and ``range/s{id}`` per cone from
each tick's readings, each message stamped (and logged) at its simulation time; and ``joy``
(``sensor_msgs/Joy``) per input a driver gave a chair from the page or a gamepad (``robot/{id}/drive``),
stamped at the simulation time of the world's last state before it (an input carries no time of
its own; the page sends them at 20 Hz, so within a tick of when the chair heard it). Any recording we write is read, its
parts included (``iw_zenoh.record.reader``).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import StoragePlugin, Writer

from iw_zenoh.convert import spec_from_msg
from iw_zenoh.errors import IwError, RecordingError
from iw_zenoh.messages import DriveInput, SensorReading, WorldInfo, WorldState
from iw_zenoh.record.reader import open_recording, print_notes
from iw_zenoh.ros2 import convert
from iw_zenoh.ros2 import types as t
from iw_zenoh.ros2.chair import CLOCK_TOPIC, TF_TOPIC, ChairTopics, namespace_of

__all__ = ["export_ros2", "main"]

PROGRESS_EVERY = 0.05  # print progress every 5% of the recording read


class _Bag:
    """The bag being written: a connection per topic, made on its first message."""

    def __init__(self, writer: Writer) -> None:
        self.writer = writer
        self.conns: dict[str, Any] = {}
        self.counts: dict[str, int] = {}

    def write(self, topic: str, type_name: str, stamp_ns: int, data: bytes) -> None:
        conn = self.conns.get(topic)
        if conn is None:
            conn = self.writer.add_connection(topic, type_name, typestore=t.store())
            self.conns[topic] = conn
        self.writer.write(conn, stamp_ns, data)
        self.counts[topic] = self.counts.get(topic, 0) + 1


def export_ros2(
    recording: str | Path,
    out: str | Path,
    *,
    namespace: str = "/robot{id}",
    progress: Callable[[float], None] | None = None,
) -> dict[str, int]:
    """Writes a recording as a rosbag2 bag in ``out`` (a folder that must not exist yet).

    Returns:
        The number of messages written per topic.

    Raises:
        RecordingError: The recording cannot be read.
        IwError: ``out`` exists already.
    """
    out = Path(out)
    if out.exists():
        raise IwError(f"{out} exists: rosbag2 writes a new folder; give -o a path that does not exist yet")
    chairs: dict[int, ChairTopics] = {}
    period_s = 0.1
    now_ns = 0  # the simulation time of the last world state read
    with open_recording(recording) as rec, Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        bag = _Bag(writer)
        done = 0.0
        for r in rec.records(("info", "state", "sensors", "drive")):
            msg = r.message
            if isinstance(msg, WorldInfo):
                period_s = msg.period_ns / 1e9 or period_s
                for spec_msg in msg.robots:
                    spec = spec_from_msg(spec_msg)
                    chairs[spec.id] = ChairTopics(spec.id, namespace_of(namespace, spec.id), spec)
            elif isinstance(msg, WorldState):
                now_ns = msg.sim_time_ns
                _state(bag, chairs, msg, period_s)
            elif isinstance(msg, SensorReading) and msg.robot_id in chairs:
                _reading(bag, chairs[msg.robot_id], msg)
            elif isinstance(msg, DriveInput) and msg.robot_id in chairs:
                _drive(bag, chairs[msg.robot_id], msg, now_ns)
            if progress is not None and rec.progress() - done >= PROGRESS_EVERY:
                done = rec.progress()
                progress(done)
        print_notes("iwz export", rec)
    if progress is not None:
        progress(1.0)
    return bag.counts


def _state(bag: _Bag, chairs: dict[int, ChairTopics], st: WorldState, period_s: float) -> None:
    links: list[tuple[str, str, float, float, float]] = []
    for i, rid in enumerate(st.ids):
        ch = chairs.get(rid)
        if ch is not None:
            bag.write(ch.odom_topic(), t.ODOMETRY, st.sim_time_ns, ch.odom(st, i, period_s))
            links += ch.links(st, i)
    if links:
        bag.write(TF_TOPIC, t.TF_MESSAGE, st.sim_time_ns, convert.tf_message(st.sim_time_ns, links))
    bag.write(CLOCK_TOPIC, t.CLOCK, st.sim_time_ns, convert.clock(st.sim_time_ns))


def _reading(bag: _Bag, ch: ChairTopics, r: SensorReading) -> None:
    for lid, data in ch.scans(r):
        bag.write(ch.scan_topic(lid), t.LASER_SCAN, r.sim_time_ns, data)
    for sid, data in ch.ranges(r):
        bag.write(ch.range_topic(sid), t.RANGE, r.sim_time_ns, data)


def _drive(bag: _Bag, ch: ChairTopics, d: DriveInput, sim_time_ns: int) -> None:
    data = convert.joy(sim_time_ns, ch.frames.base, x=d.x, y=d.y, buttons=d.buttons)
    bag.write(ch.joy_topic(), t.JOY, sim_time_ns, data)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz export``."""
    p = argparse.ArgumentParser(
        prog="iwz export",
        description="Export a recording for other tools. --ros2: a rosbag2 bag (MCAP, CDR) ROS 2 tools read.",
        epilog=(
            "Examples:\n"
            "  iwz export --ros2 recordings/run.mcap -o run_bag      a rosbag2 folder: run_bag/metadata.yaml, *.mcap\n"
            "  ros2 bag info run_bag                                 (ROS 2 Jazzy) what it holds\n"
            "  ros2 bag play run_bag --clock                         play it to a ROS 2 stack, sim time\n"
            "docs/ros2.md has the topics, types and frames."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("recording", help="the recording (any part of a recording of several)")
    p.add_argument("--ros2", action="store_true", required=True, help="write a rosbag2 bag (the only format yet)")
    p.add_argument("-o", "--output", required=True, help="the bag's folder (must not exist)")
    p.add_argument("--namespace", default="/robot{id}", help="each chair's namespace; {id} is its id")
    p.add_argument("--quiet", action="store_true", help="no progress")
    args = p.parse_args(argv)

    def show(fraction: float) -> None:
        print(f"iwz export: {fraction:4.0%}", file=sys.stderr, flush=True)

    try:
        counts = export_ros2(
            args.recording, args.output, namespace=args.namespace, progress=None if args.quiet else show
        )
    except (RecordingError, IwError, OSError) as e:
        print(f"iwz export: {e}", file=sys.stderr, flush=True)
        return 2
    for topic, n in sorted(counts.items()):
        print(f"{topic}\t{n}")
    return 0
