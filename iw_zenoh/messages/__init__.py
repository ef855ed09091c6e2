"""Every wire message of iw-zenoh, with the one ``encode`` and the one ``decode``.

UTF-8 JSON on the wire (readable in any MCAP viewer or raw subscriber), one ``msgspec.Struct``
per message; msgspec validates types on decode and writes each message's JSON Schema. Every
message carries ``tick`` and ``sim_time_ns``; robot-scoped ones carry ``robot_id``. Batched
messages (proposed, verdict, state) carry arrays, so a tick costs a handful of messages however
many robots there are. ``revision`` counts changes of the roster and of the obstacles: a node
that sees one it does not know asks ``world/info`` again.
"""

from __future__ import annotations

from iw_zenoh.messages.drive import ASSIST_LEVELS, DEADMAN, DriveInput, DriveState
from iw_zenoh.messages.events import (
    EVENT_PAYLOADS,
    AgentLostData,
    BadMessageData,
    CollisionData,
    Control,
    Event,
    EventData,
    EventKind,
    LaggardData,
    LegacyRefusedData,
    NoData,
    ObstacleData,
    RadioDroppedData,
    RefusedData,
    RegisteredData,
    SerialLinkData,
    event_payload,
    make_event,
)
from iw_zenoh.messages.robot import (
    ActionBatch,
    Actions,
    ChairReading,
    Hear,
    Heard,
    LaserScan,
    PoseReport,
    RadioBatch,
    Say,
    SensorBatch,
    SensorReading,
    encode_sensor_batch,
    readings_of,
)
from iw_zenoh.messages.wire import COORD_LIMIT, Message, Outgoing, decode, encode, json_schema, stamp_of
from iw_zenoh.messages.wire import prepare_decoders as _prepare_decoders
from iw_zenoh.messages.world import (
    BumperMsg,
    Hit,
    IrSensorMsg,
    LabMsg,
    LaserMsg,
    NoiseMsg,
    Obstacle,
    Proposed,
    RegisterReply,
    RegisterRequest,
    RobotSpecMsg,
    SensorNoiseMsg,
    Tick,
    Verdict,
    WallMsg,
    WorldInfo,
    WorldState,
)

__all__ = [
    "ASSIST_LEVELS",
    "COORD_LIMIT",
    "DEADMAN",
    "DriveInput",
    "DriveState",
    "MESSAGE_TYPES",
    "Actions",
    "Control",
    "EVENT_PAYLOADS",
    "AgentLostData",
    "BadMessageData",
    "CollisionData",
    "Event",
    "EventData",
    "EventKind",
    "LaggardData",
    "LegacyRefusedData",
    "NoData",
    "ObstacleData",
    "RadioDroppedData",
    "RefusedData",
    "RegisteredData",
    "BumperMsg",
    "IrSensorMsg",
    "LaserMsg",
    "LaserScan",
    "NoiseMsg",
    "SensorNoiseMsg",
    "WallMsg",
    "Heard",
    "Hear",
    "Hit",
    "LabMsg",
    "Message",
    "Obstacle",
    "Outgoing",
    "PoseReport",
    "Proposed",
    "ActionBatch",
    "ChairReading",
    "RadioBatch",
    "RegisterReply",
    "RegisterRequest",
    "RobotSpecMsg",
    "Say",
    "SensorBatch",
    "SensorReading",
    "SerialLinkData",
    "TOPIC_TYPES",
    "Tick",
    "Verdict",
    "WorldInfo",
    "WorldState",
    "decode",
    "encode",
    "event_payload",
    "make_event",
    "encode_sensor_batch",
    "readings_of",
    "json_schema",
    "stamp_of",
]

MESSAGE_TYPES: tuple[type[Message], ...] = (
    RegisterRequest,
    RegisterReply,
    WorldInfo,
    Tick,
    Proposed,
    Verdict,
    WorldState,
    Actions,
    ActionBatch,
    PoseReport,
    ChairReading,
    SensorReading,
    SensorBatch,
    Say,
    Hear,
    RadioBatch,
    Control,
    Event,
    DriveInput,
    DriveState,
)

TOPIC_TYPES: dict[str, type[Message]] = {
    "info": WorldInfo,
    "tick": Tick,
    "proposed": Proposed,
    "verdict": Verdict,
    "state": WorldState,
    "control": Control,
    "radio": RadioBatch,
    "sensor_batch": SensorBatch,
    "action_batch": ActionBatch,
    "event": Event,
    "spec": RegisterReply,
    "actions": Actions,
    "pose_report": PoseReport,
    "chair": ChairReading,
    "sensors": SensorReading,
    "say": Say,
    "hear": Hear,
    "drive": DriveInput,
    "driving": DriveState,
}  # the message type of each kind of key (see keys.topic_kind)

# every message's decoder made now, before a process starts its threads (why: prepare_decoders)
from iw_zenoh.messages import events as _events  # noqa: E402
from iw_zenoh.messages import robot as _robot  # noqa: E402
from iw_zenoh.messages import world as _world  # noqa: E402

_prepare_decoders(_events, _robot, _world)
