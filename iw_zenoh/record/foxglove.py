"""The Foxglove view of a simulation: a scene channel (walls, bodies, proximity cones, names),
frame transforms and each laser scanner's scans (``foxglove.LaserScan``, one channel per
scanner, in its robot's frame), derived from the world's own messages while recording, so a recording
opens in Foxglove's 3D panel. The ``Fg*`` structs are the Foxglove schemas those channels carry:
derived channels of a recording, never messages of the simulation's own wire."""

from __future__ import annotations

import math
from typing import Annotated, Any, ClassVar

import msgspec

from iw_zenoh.convert import spec_from_msg
from iw_zenoh.core.spec import RobotSpec
from iw_zenoh.messages import SensorReading, WorldInfo, WorldState

__all__ = [
    "LASER_TOPIC",
    "SCENE_TOPIC",
    "TF_TOPIC",
    "FgColor",
    "FgCube",
    "FgEntity",
    "FgFrameTransform",
    "FgLaserScan",
    "FgLine",
    "FgPose",
    "FgQuaternion",
    "FgSceneUpdate",
    "FgText",
    "FgTime",
    "FgVector3",
    "SceneBuilder",
]

NonNeg = Annotated[int, msgspec.Meta(ge=0)]

# --- Foxglove scene: derived channels the recorder adds so a recording opens in a 3D view ----
# Field names follow Foxglove's published schemas (foxglove.SceneUpdate, foxglove.FrameTransform);
# the schema names are what Foxglove recognises.


class FgTime(msgspec.Struct, frozen=True):
    """Foxglove time / duration."""

    sec: NonNeg = 0
    nsec: Annotated[int, msgspec.Meta(ge=0, le=999_999_999)] = 0


class FgVector3(msgspec.Struct, frozen=True):
    """A 3D vector (m)."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


class FgQuaternion(msgspec.Struct, frozen=True):
    """A rotation."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0


class FgPose(msgspec.Struct, frozen=True):
    """Position and orientation."""

    position: FgVector3 = FgVector3()
    orientation: FgQuaternion = FgQuaternion()


class FgColor(msgspec.Struct, frozen=True):
    """RGBA in [0, 1]."""

    r: float = 0.5
    g: float = 0.5
    b: float = 0.5
    a: float = 1.0


class FgCube(msgspec.Struct, frozen=True):
    """foxglove.CubePrimitive."""

    pose: FgPose
    size: FgVector3
    color: FgColor


class FgLine(msgspec.Struct, frozen=True):
    """foxglove.LinePrimitive (type 0 strip, 1 loop, 2 list)."""

    type: int
    pose: FgPose
    thickness: float
    scale_invariant: bool
    points: list[FgVector3]
    color: FgColor
    colors: list[FgColor] = []
    indices: list[int] = []


class FgText(msgspec.Struct, frozen=True):
    """foxglove.TextPrimitive."""

    pose: FgPose
    billboard: bool
    font_size: float
    scale_invariant: bool
    color: FgColor
    text: str


class FgEntity(msgspec.Struct, frozen=True):
    """foxglove.SceneEntity."""

    timestamp: FgTime
    frame_id: str
    id: str
    lifetime: FgTime = FgTime()
    frame_locked: bool = False
    metadata: list[dict[str, str]] = []
    arrows: list[dict[str, Any]] = []
    cubes: list[FgCube] = []
    spheres: list[dict[str, Any]] = []
    cylinders: list[dict[str, Any]] = []
    lines: list[FgLine] = []
    triangles: list[dict[str, Any]] = []
    texts: list[FgText] = []
    models: list[dict[str, Any]] = []


class FgSceneUpdate(msgspec.Struct, frozen=True):
    """foxglove.SceneUpdate."""

    schema: ClassVar[str] = "foxglove.SceneUpdate"
    deletions: list[dict[str, Any]] = []
    entities: list[FgEntity] = []


class FgFrameTransform(msgspec.Struct, frozen=True):
    """foxglove.FrameTransform."""

    schema: ClassVar[str] = "foxglove.FrameTransform"
    timestamp: FgTime
    parent_frame_id: str
    child_frame_id: str
    translation: FgVector3
    rotation: FgQuaternion


class FgLaserScan(msgspec.Struct, frozen=True):
    """foxglove.LaserScan: ranges at equally spaced bearings from ``start_angle`` to ``end_angle``
    (radians, about +z from the pose's +x). JSON has no infinity: a beam that met nothing within
    range is written as range 0 with intensity 0; every hit has intensity 1."""

    schema: ClassVar[str] = "foxglove.LaserScan"
    timestamp: FgTime
    frame_id: str
    pose: FgPose
    start_angle: float
    end_angle: float
    ranges: list[float]
    intensities: list[float]


Derived = tuple[str, FgSceneUpdate | FgFrameTransform | FgLaserScan]  # a derived channel's message

SCENE_TOPIC = "/foxglove/scene"
LASER_TOPIC = "/foxglove/laser"  # + /{robot id}/{scanner id}
TF_TOPIC = "/foxglove/tf"
FRAME = "world"
WALL = FgColor(r=0.35, g=0.35, b=0.38, a=1.0)
BODY = FgColor(r=0.15, g=0.45, b=0.85, a=0.9)
HIT = FgColor(r=0.9, g=0.1, b=0.1, a=0.9)
CONE = FgColor(r=1.0, g=0.6, b=0.0, a=0.6)
BODY_HEIGHT_M = 1.0  # drawn height of a chair
ARC_POINTS = 8


def _time(ns: int) -> FgTime:
    return FgTime(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)


def _yaw(theta: float) -> FgQuaternion:
    return FgQuaternion(x=0.0, y=0.0, z=math.sin(theta / 2), w=math.cos(theta / 2))


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
                pts = [FgVector3(x=x, y=y, z=z) for x, y in w.corners]
                lines.append(
                    FgLine(type=1, pose=FgPose(), thickness=0.04, scale_invariant=False, points=pts, color=WALL)
                )
        border = [
            FgVector3(x=x, y=y, z=0.0)
            for x, y in ((0, 0), (info.lab.width, 0), (info.lab.width, info.lab.height), (0, info.lab.height))
        ]
        lines.append(FgLine(type=1, pose=FgPose(), thickness=0.08, scale_invariant=False, points=border, color=WALL))
        ent = FgEntity(timestamp=_time(info.sim_time_ns), frame_id=FRAME, id="walls", lines=lines)
        return [(SCENE_TOPIC, FgSceneUpdate(entities=[ent]))]

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
            cube = FgCube(
                pose=FgPose(position=FgVector3(x=cx, y=cy, z=BODY_HEIGHT_M / 2), orientation=_yaw(th)),
                size=FgVector3(x=spec.width_m, y=spec.height_m, z=BODY_HEIGHT_M),
                color=HIT if hit else BODY,
            )
            label = FgText(
                pose=FgPose(position=FgVector3(x=x, y=y, z=BODY_HEIGHT_M + 0.3)),
                billboard=True,
                font_size=14.0,
                scale_invariant=True,
                color=FgColor(r=1.0, g=1.0, b=1.0, a=1.0),
                text=f"{rid} {spec.name}",
            )
            entities.append(FgEntity(timestamp=ts, frame_id=FRAME, id=f"robot/{rid}", cubes=[cube], texts=[label]))
            out.append(
                (
                    TF_TOPIC,
                    FgFrameTransform(
                        timestamp=ts,
                        parent_frame_id=FRAME,
                        child_frame_id=f"robot{rid}",
                        translation=FgVector3(x=x, y=y),
                        rotation=_yaw(th),
                    ),
                )
            )
        if len(self.pose) > len(st.ids):  # robots that left: their last pose is of no use
            self.pose = {rid: self.pose[rid] for rid in st.ids}
        out.insert(0, (SCENE_TOPIC, FgSceneUpdate(entities=entities)))
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
            pts = [FgVector3(x=ox, y=oy, z=0.3)]
            for k in range(ARC_POINTS + 1):
                a = phi - half + 2 * half * k / ARC_POINTS
                pts.append(FgVector3(x=ox + reach * math.cos(a), y=oy + reach * math.sin(a), z=0.3))
            color = CONE if dist is not None else FgColor(r=0.6, g=0.6, b=0.6, a=0.25)
            lines.append(FgLine(type=1, pose=FgPose(), thickness=0.02, scale_invariant=False, points=pts, color=color))
        ent = FgEntity(timestamp=_time(r.sim_time_ns), frame_id=FRAME, id=f"cones/{r.robot_id}", lines=lines)
        return [(SCENE_TOPIC, FgSceneUpdate(entities=[ent])), *_scans(r, spec)]


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
        msg = FgLaserScan(
            timestamp=_time(r.sim_time_ns),
            frame_id=f"robot{r.robot_id}",
            pose=FgPose(position=FgVector3(x=a.x_m, y=a.y_m, z=0.3)),
            start_angle=start,
            end_angle=start + math.radians(a.resolution_deg) * (a.beams - 1),
            ranges=[0.0 if v is None else v for v in scan.ranges],
            intensities=[0.0 if v is None else 1.0 for v in scan.ranges],
        )
        out.append((f"{LASER_TOPIC}/{r.robot_id}/{scan.id}", msg))
    return out
