"""The Foxglove view of a simulation: a scene channel (walls, bodies, proximity cones, names),
frame transforms and each laser scanner's scans (one channel per scanner, in its robot's frame),
derived from the world's own messages while recording and live, so a recording opens in Foxglove's
and Lichtblick's 3D panel. They are Foxglove's own well-known types (``foxglove.SceneUpdate``,
``foxglove.FrameTransform``, ``foxglove.LaserScan``), built with foxglove-sdk and written in its
protobuf encoding with its schemas: those tools draw them natively, every entity kind is typed by
Foxglove's own schema, and a laser beam that met nothing is an infinite range, which draws no point
(JSON has no infinity). Derived channels of a recording, never messages of the simulation's own wire."""

from __future__ import annotations

import math
from typing import TypeAlias

from foxglove.messages import (
    Color,
    CubePrimitive,
    FrameTransform,
    LaserScan,
    LinePrimitive,
    LinePrimitiveLineType,
    Point3,
    Pose,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    TextPrimitive,
    Timestamp,
    Vector3,
)

from iw_zenoh.convert import spec_from_msg
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import SensorReading, WorldInfo, WorldState

__all__ = ["LASER_TOPIC", "SCENE_TOPIC", "TF_TOPIC", "Derived", "DerivedMessage", "SceneBuilder"]

DerivedMessage: TypeAlias = SceneUpdate | FrameTransform | LaserScan  # what a derived channel carries
Derived: TypeAlias = tuple[str, DerivedMessage]  # a derived channel's topic and message

SCENE_TOPIC = "/foxglove/scene"
LASER_TOPIC = "/foxglove/laser"  # + /{robot id}/{scanner id}
TF_TOPIC = "/foxglove/tf"
FRAME = "world"
WALL = Color(r=0.35, g=0.35, b=0.38, a=1.0)
BODY = Color(r=0.15, g=0.45, b=0.85, a=0.9)
HIT = Color(r=0.9, g=0.1, b=0.1, a=0.9)
CONE = Color(r=1.0, g=0.6, b=0.0, a=0.6)
BODY_HEIGHT_M = 1.0  # drawn height of a chair
ARC_POINTS = 8
LOOP = LinePrimitiveLineType.LineLoop
MISS = math.inf  # the range of a beam that met nothing: Foxglove draws no point for it


def _time(ns: int) -> Timestamp:
    return Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)


def _pose(x: float = 0.0, y: float = 0.0, z: float = 0.0, q: Quaternion | None = None) -> Pose:
    return Pose(position=Vector3(x=x, y=y, z=z), orientation=q if q is not None else Quaternion(w=1.0))


def _yaw(theta: float) -> Quaternion:
    return Quaternion(x=0.0, y=0.0, z=math.sin(theta / 2), w=math.cos(theta / 2))


class SceneBuilder:
    """Turns info, state and sensor messages into Foxglove scene updates and transforms."""

    def __init__(self) -> None:
        self.specs: dict[int, RobotSpec] = {}
        self.pose: dict[int, tuple[float, float, float]] = {}
        self._walls_sent_for: int = -1

    def on_info(self, info: WorldInfo) -> list[Derived]:
        """Walls (once per revision) and the robots' bodies to come."""
        self.specs = {s.id: spec_from_msg(s) for s in info.robots}
        if info.revision == self._walls_sent_for:
            return []
        self._walls_sent_for = info.revision
        lines = []
        for w in info.lab.walls:
            for z in (0.0, w.height):
                pts = [Point3(x=x, y=y, z=z) for x, y in w.corners]
                lines.append(
                    LinePrimitive(
                        type=LOOP, pose=_pose(), thickness=0.04, scale_invariant=False, points=pts, color=WALL
                    )
                )
        border = [
            Point3(x=x, y=y, z=0.0)
            for x, y in ((0, 0), (info.lab.width, 0), (info.lab.width, info.lab.height), (0, info.lab.height))
        ]
        lines.append(
            LinePrimitive(type=LOOP, pose=_pose(), thickness=0.08, scale_invariant=False, points=border, color=WALL)
        )
        ent = SceneEntity(timestamp=_time(info.sim_time_ns), frame_id=FRAME, id="walls", lines=lines)
        return [(SCENE_TOPIC, SceneUpdate(entities=[ent]))]

    def on_state(self, st: WorldState) -> list[Derived]:
        """Every body at its committed pose, and a transform per robot."""
        if not self.specs:
            return []  # no world description yet: nothing to draw bodies with
        ts = _time(st.sim_time_ns)
        entities = []
        out: list[Derived] = []
        for rid, x, y, th, hit in zip(st.ids, st.x, st.y, st.heading, st.collided, strict=True):
            self.pose[rid] = (x, y, th)
            spec = self.specs.get(rid)
            if spec is None:
                continue
            off = spec.width_m * (spec.com - 0.5)  # body centre ahead of the wheel axis
            cx, cy = x - off * math.cos(th), y - off * math.sin(th)
            cube = CubePrimitive(
                pose=_pose(cx, cy, BODY_HEIGHT_M / 2, _yaw(th)),
                size=Vector3(x=spec.width_m, y=spec.height_m, z=BODY_HEIGHT_M),
                color=HIT if hit else BODY,
            )
            label = TextPrimitive(
                pose=_pose(x, y, BODY_HEIGHT_M + 0.3),
                billboard=True,
                font_size=14.0,
                scale_invariant=True,
                color=Color(r=1.0, g=1.0, b=1.0, a=1.0),
                text=f"{rid} {spec.name}",
            )
            entities.append(SceneEntity(timestamp=ts, frame_id=FRAME, id=f"robot/{rid}", cubes=[cube], texts=[label]))
            out.append(
                (
                    TF_TOPIC,
                    FrameTransform(
                        timestamp=ts,
                        parent_frame_id=FRAME,
                        child_frame_id=f"robot{rid}",
                        translation=Vector3(x=x, y=y, z=0.0),
                        rotation=_yaw(th),
                    ),
                )
            )
        if len(self.pose) > len(st.ids):  # robots that left: their last pose is of no use
            self.pose = {rid: self.pose[rid] for rid in st.ids}
        out.insert(0, (SCENE_TOPIC, SceneUpdate(entities=entities)))
        return out

    def on_sensors(self, r: SensorReading) -> list[Derived]:
        """A robot's proximity cones, drawn to their readings, and its laser scans."""
        spec = self.specs.get(r.robot_id)
        pose = self.pose.get(r.robot_id)
        if spec is None or pose is None:
            return []
        x, y, th = pose
        by_id = {s.id: s for s in spec.sensors}
        lines = []
        for sid, dist in zip(r.proximity_ids, r.proximity_m, strict=False):
            s = by_id.get(sid)
            if s is None:
                continue
            ox = x + math.cos(th) * s.x_m - math.sin(th) * s.y_m
            oy = y + math.sin(th) * s.x_m + math.cos(th) * s.y_m
            reach = s.range_m if dist is None else dist
            phi = th + math.radians(s.angle_deg)
            half = math.radians(s.cone_deg) / 2
            pts = [Point3(x=ox, y=oy, z=0.3)]
            for k in range(ARC_POINTS + 1):
                a = phi - half + 2 * half * k / ARC_POINTS
                pts.append(Point3(x=ox + reach * math.cos(a), y=oy + reach * math.sin(a), z=0.3))
            color = CONE if dist is not None else Color(r=0.6, g=0.6, b=0.6, a=0.25)
            lines.append(
                LinePrimitive(type=LOOP, pose=_pose(), thickness=0.02, scale_invariant=False, points=pts, color=color)
            )
        ent = SceneEntity(timestamp=_time(r.sim_time_ns), frame_id=FRAME, id=f"cones/{r.robot_id}", lines=lines)
        return [(SCENE_TOPIC, SceneUpdate(entities=[ent])), *_scans(r, spec)]


def _scans(r: SensorReading, spec: RobotSpec) -> list[Derived]:
    """One ``foxglove.LaserScan`` per scanner the reading carries, in its robot's frame."""
    if not isinstance(r.lasers, list):
        return []
    by_id = {a.id: a for a in spec.lasers}
    out: list[Derived] = []
    for scan in r.lasers:
        a = by_id.get(scan.id)
        if a is None or len(scan.ranges) != a.beams:
            continue
        start = math.radians(a.start_deg)
        msg = LaserScan(
            timestamp=_time(r.sim_time_ns),
            frame_id=f"robot{r.robot_id}",
            pose=_pose(a.x_m, a.y_m, 0.3),
            start_angle=start,
            end_angle=start + math.radians(a.resolution_deg) * (a.beams - 1),
            ranges=[MISS if v is None else v for v in scan.ranges],
            intensities=[0.0 if v is None else 1.0 for v in scan.ranges],
        )
        out.append((f"{LASER_TOPIC}/{r.robot_id}/{scan.id}", msg))
    return out
