"""One chair as ROS 2 sees it: its namespace, topics and frames, and the payloads of a tick (its
odom from the world's state, a scan per laser and a range per cone from its readings, its links
in /tf). Pure: ``iwz ros2`` publishes them live, ``iwz export --ros2`` writes them to a bag."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import SensorReading, WorldState
from iw_zenoh.ros2 import convert

__all__ = ["CLOCK_TOPIC", "TF_TOPIC", "ChairTopics", "namespace_of"]

Link = tuple[str, str, float, float, float]  # parent, child, x, y, heading
TF_TOPIC, CLOCK_TOPIC = "/tf", "/clock"


def namespace_of(template: str, robot_id: int) -> str:
    """A chair's namespace from its template (``/robot{id}`` -> ``/robot1``)."""
    return "/" + template.format(id=robot_id).strip("/")


@dataclass(frozen=True)
class ChairTopics:
    """A chair's names and payloads.

    Attributes:
        robot_id: Its id.
        namespace: Its namespace (``/robot1``).
        spec: Its accepted spec (lasers, cones, wheel base).
    """

    robot_id: int
    namespace: str
    spec: RobotSpec

    @property
    def frames(self) -> convert.Frames:
        """Its frame names, under its namespace."""
        return convert.Frames.of(self.namespace)

    def odom_topic(self) -> str:
        """The topic of its odometry (``nav_msgs/Odometry``)."""
        return f"{self.namespace}/odom"

    def cmd_vel_topic(self) -> str:
        """The topic it takes its velocity commands from (``geometry_msgs/Twist``)."""
        return f"{self.namespace}/cmd_vel"

    def scan_topic(self, laser_id: int) -> str:
        """``scan`` for a chair's only scanner, ``scan{id}`` for each of several."""
        return f"{self.namespace}/scan" if len(self.spec.lasers) == 1 else f"{self.namespace}/scan{laser_id}"

    def joy_topic(self) -> str:
        """The topic of its driver's inputs in an exported bag (``sensor_msgs/Joy``)."""
        return f"{self.namespace}/joy"

    def range_topic(self, sensor_id: int) -> str:
        """The topic of its proximity sensor ``sensor_id`` (``sensor_msgs/Range``)."""
        return f"{self.namespace}/range/s{sensor_id}"

    def odom(self, st: WorldState, i: int, period_s: float) -> bytes:
        """Its odom of a state (row ``i``): the pose, and the tick's velocity from its wheels."""
        turn = (st.rolled_right[i] - st.rolled_left[i]) / self.spec.height_m
        pose = convert.Pose2(st.x[i], st.y[i], st.heading[i], v=st.speed[i], w=turn / period_s)
        return convert.odometry(self.frames, st.sim_time_ns, pose)

    def links(self, st: WorldState, i: int) -> list[Link]:
        """Its transforms: odom -> base_link at the state's pose, base_link -> each sensor where it is mounted."""
        f, base = self.frames, self.frames.base
        out: list[Link] = [(f.odom, base, st.x[i], st.y[i], st.heading[i])]
        out += [(base, f.name(f"laser{s.id}"), s.x_m, s.y_m, math.radians(s.angle_deg)) for s in self.spec.lasers]
        out += [(base, f.name(f"range{s.id}"), s.x_m, s.y_m, math.radians(s.angle_deg)) for s in self.spec.ir_sensors]
        return out

    def scans(self, reading: SensorReading) -> Iterator[tuple[int, bytes]]:
        """(laser id, LaserScan) of each of its scanners the reading holds."""
        got = {s.id: s.ranges for s in reading.lasers} if isinstance(reading.lasers, list) else {}
        for laser in self.spec.lasers:
            if laser.id in got:
                yield (
                    laser.id,
                    convert.laser_scan(
                        self.frames.name(f"laser{laser.id}"),
                        reading.sim_time_ns,
                        angle_deg=laser.angle_deg,
                        fov_deg=laser.fov_deg,
                        range_m=laser.range_m,
                        ranges=got[laser.id],
                        scan_time_s=0.0,
                    ),
                )

    def ranges(self, reading: SensorReading) -> Iterator[tuple[int, bytes]]:
        """(sensor id, Range) of each of its cones the reading holds."""
        cones = {ir.id: ir for ir in self.spec.ir_sensors}
        for sid, value in zip(reading.proximity_ids, reading.proximity_m, strict=True):
            ir = cones.get(sid)
            if ir is not None:
                frame = self.frames.name(f"range{sid}")
                yield (
                    sid,
                    convert.range_reading(
                        frame, reading.sim_time_ns, cone_deg=ir.cone_deg, range_m=ir.range_m, value=value
                    ),
                )
