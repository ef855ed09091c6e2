"""Every Zenoh key expression of iw-zenoh, and nowhere else.

All keys live under ``iw/{sim}/`` so several simulations (and a replay beside a live run) share
one network::

    iw/{sim}/world/info              queryable: map, parameters, robots (for late joiners)
    iw/{sim}/world/register          queryable: RegisterRequest in, RegisterReply out
    iw/{sim}/world/register/{agent}  the same, asked by the agent it names (attributable: secured runs)
    iw/{sim}/world/tick              clock
    iw/{sim}/world/proposed          next poses of all robots (batched)
    iw/{sim}/world/verdict           collision verdicts (batched)
    iw/{sim}/world/state             committed poses (batched)
    iw/{sim}/world/control           start, pause, step, stop, remove robot, obstacles
    iw/{sim}/world/radio             everything the radio delivered in a tick (batched)
    iw/{sim}/world/sensors/{K}-{N}   every reading one sensors shard computed in a tick (batched)
    iw/{sim}/agent/{name}/actions    every hosted robot's actions of one agent process (batched)
    iw/{sim}/events/{kind}           what happened, for people and tools
    iw/{sim}/robot/{id}/spec         the accepted spec
    iw/{sim}/robot/{id}/actions      motor powers, leds
    iw/{sim}/robot/{id}/pose_report  a Real robot's own pose
    iw/{sim}/robot/{id}/chair        a real chair's own readings (serial bridge)
    iw/{sim}/robot/{id}/sensors      readings of one tick
    iw/{sim}/robot/{id}/say          a radio message to send
    iw/{sim}/robot/{id}/hear         radio messages heard this tick
    iw/{sim}/robot/{id}/drive        a driver's input to a chair (docs/driving.md)
    iw/{sim}/robot/{id}/driving      the chair's drive state (its own agent publishes it)
    iw/{sim}/alive/{role}/{name}     liveliness tokens
"""

from __future__ import annotations

import re

__all__ = [
    "ROLES",
    "all_registers",
    "is_control",
    "register_agent_of",
    "actions",
    "agent_actions",
    "agent_of",
    "alive",
    "all_actions",
    "all_agent_actions",
    "all_alive",
    "all_chairs",
    "all_drive",
    "all_driving",
    "all_events",
    "all_hear",
    "all_pose_reports",
    "alive_parts",
    "all_say",
    "all_sensor_batches",
    "all_sensors",
    "all_specs",
    "chair",
    "chunk",
    "control",
    "drive",
    "driving",
    "event",
    "everything",
    "hear",
    "info",
    "pose_report",
    "proposed",
    "radio",
    "register",
    "robot_id_of",
    "ros2_all_tokens",
    "ros2_everything",
    "ros2_in_every_namespace",
    "ros2_token",
    "ros2_topic",
    "say",
    "sensor_batch",
    "sensors",
    "spec",
    "state",
    "sim_of",
    "tick",
    "topic_kind",
    "valid_robot_id",
    "verdict",
    "with_sim",
]

ROLES = (
    "router",
    "world",
    "collision",
    "sensors",
    "radio",
    "recorder",
    "replay",
    "viewer",
    "bridge",
    "agent",
    "launcher",
)
_FORBIDDEN = re.compile(r"[/*$?#\s]")
_ROBOT_KEY = re.compile(r"^iw/[^/]+/robot/(\d+)/[a-z_]+$")


def chunk(name: str) -> str:
    """Validates one key chunk (a sim name, a role, an instance name).

    Args:
        name: The chunk.

    Returns:
        The same chunk.

    Raises:
        ValueError: When it is empty or holds ``/ * $ ? #`` or white space.
    """
    if not name or _FORBIDDEN.search(name):
        raise ValueError(f"{name!r} is not a valid key chunk: it must be non-empty and free of / * $ ? # and spaces")
    return name


def valid_robot_id(robot_id: int) -> int:
    """Validates a robot id (every builder of a robot's key does).

    Args:
        robot_id: The id.

    Returns:
        The same id.

    Raises:
        ValueError: When it is not a non-negative integer.
    """
    if isinstance(robot_id, bool) or not isinstance(robot_id, int) or robot_id < 0:
        raise ValueError(f"robot id must be a non-negative integer, got {robot_id!r}")
    return robot_id


def everything(sim: str) -> str:
    """Every key of a simulation (what the recorder subscribes to)."""
    return f"iw/{chunk(sim)}/**"


def info(sim: str) -> str:
    """The world's information queryable."""
    return f"iw/{chunk(sim)}/world/info"


def register(sim: str, agent: str = "") -> str:
    """The registration queryable; with ``agent``, its key for that agent's own requests."""
    return f"iw/{chunk(sim)}/world/register" + (f"/{chunk(agent)}" if agent else "")


def all_registers(sim: str) -> str:
    """Every registration key (the world serves them all)."""
    return f"iw/{chunk(sim)}/world/register/**"


def register_agent_of(key: str) -> str | None:
    """The agent a registration key names (``""`` for the shared key), or ``None`` for another key."""
    parts = str(key).split("/")
    if len(parts) in (4, 5) and parts[0] == "iw" and parts[2:4] == ["world", "register"]:
        return parts[4] if len(parts) == 5 else ""
    return None


def tick(sim: str) -> str:
    """The clock."""
    return f"iw/{chunk(sim)}/world/tick"


def proposed(sim: str) -> str:
    """Proposed poses (world to collision)."""
    return f"iw/{chunk(sim)}/world/proposed"


def verdict(sim: str) -> str:
    """Collision verdicts (collision to world)."""
    return f"iw/{chunk(sim)}/world/verdict"


def state(sim: str) -> str:
    """Committed state (world to everyone)."""
    return f"iw/{chunk(sim)}/world/state"


def control(sim: str) -> str:
    """Control commands to the world."""
    return f"iw/{chunk(sim)}/world/control"


def is_control(key: str) -> bool:
    """Whether ``key`` is a simulation's control key (:func:`control`), whatever the simulation."""
    return key.startswith("iw/") and key.endswith("/world/control") and key.count("/") == 3


def radio(sim: str) -> str:
    """Everything the radio delivered in a tick (batched, for agent hosts)."""
    return f"iw/{chunk(sim)}/world/radio"


def sensor_batch(sim: str, shard: tuple[int, int]) -> str:
    """Every reading one sensors shard ``(K, N)`` computed in a tick (batched)."""
    k, n = shard
    if not (isinstance(k, int) and isinstance(n, int) and 1 <= k <= n):
        raise ValueError(f"a shard is K/N with 1 <= K <= N, got {shard!r}")
    return f"iw/{chunk(sim)}/world/sensors/{k}-{n}"


def all_sensor_batches(sim: str) -> str:
    """Every shard's sensor batches."""
    return f"iw/{chunk(sim)}/world/sensors/*"


def agent_actions(sim: str, agent: str) -> str:
    """Every hosted robot's actions of one agent process (batched)."""
    return f"iw/{chunk(sim)}/agent/{chunk(agent)}/actions"


def agent_of(key: str) -> str | None:
    """The agent name in an ``agent/{name}/actions`` key, or ``None`` for any other key."""
    parts = str(key).split("/")
    if len(parts) == 5 and parts[0] == "iw" and parts[2] == "agent" and parts[4] == "actions":
        return parts[3]
    return None


def all_agent_actions(sim: str) -> str:
    """Every agent process's batched actions."""
    return f"iw/{chunk(sim)}/agent/*/actions"


def event(sim: str, kind: str) -> str:
    """Events of one kind."""
    return f"iw/{chunk(sim)}/events/{chunk(kind)}"


def all_events(sim: str) -> str:
    """Events of every kind."""
    return f"iw/{chunk(sim)}/events/*"


def spec(sim: str, robot_id: int) -> str:
    """A robot's accepted spec."""
    return f"iw/{chunk(sim)}/robot/{valid_robot_id(robot_id)}/spec"


def actions(sim: str, robot_id: int) -> str:
    """A robot's actions."""
    return f"iw/{chunk(sim)}/robot/{valid_robot_id(robot_id)}/actions"


def all_actions(sim: str) -> str:
    """Every robot's actions."""
    return f"iw/{chunk(sim)}/robot/*/actions"


def pose_report(sim: str, robot_id: int) -> str:
    """A Real robot's pose report."""
    return f"iw/{chunk(sim)}/robot/{valid_robot_id(robot_id)}/pose_report"


def all_pose_reports(sim: str) -> str:
    """Every Real robot's pose reports."""
    return f"iw/{chunk(sim)}/robot/*/pose_report"


def all_specs(sim: str) -> str:
    """Every robot's accepted spec."""
    return f"iw/{chunk(sim)}/robot/*/spec"


def chair(sim: str, robot_id: int) -> str:
    """A real chair's own readings (its serial bridge publishes them)."""
    return f"iw/{chunk(sim)}/robot/{valid_robot_id(robot_id)}/chair"


def all_chairs(sim: str) -> str:
    """Every real chair's own readings."""
    return f"iw/{chunk(sim)}/robot/*/chair"


def sensors(sim: str, robot_id: int) -> str:
    """A robot's sensor readings."""
    return f"iw/{chunk(sim)}/robot/{valid_robot_id(robot_id)}/sensors"


def all_sensors(sim: str) -> str:
    """Every robot's sensor readings."""
    return f"iw/{chunk(sim)}/robot/*/sensors"


def say(sim: str, robot_id: int) -> str:
    """A robot's outgoing radio message."""
    return f"iw/{chunk(sim)}/robot/{valid_robot_id(robot_id)}/say"


def all_say(sim: str) -> str:
    """Every robot's outgoing radio messages."""
    return f"iw/{chunk(sim)}/robot/*/say"


def hear(sim: str, robot_id: int) -> str:
    """Radio messages a robot heard."""
    return f"iw/{chunk(sim)}/robot/{valid_robot_id(robot_id)}/hear"


def all_hear(sim: str) -> str:
    """Radio messages every robot heard."""
    return f"iw/{chunk(sim)}/robot/*/hear"


def drive(sim: str, robot_id: int) -> str:
    """A driver's input to a chair (``DriveInput``)."""
    return f"iw/{chunk(sim)}/robot/{valid_robot_id(robot_id)}/drive"


def all_drive(sim: str) -> str:
    """Every chair's driver input."""
    return f"iw/{chunk(sim)}/robot/*/drive"


def driving(sim: str, robot_id: int) -> str:
    """A chair's drive state (``DriveState``, its own agent publishes it)."""
    return f"iw/{chunk(sim)}/robot/{valid_robot_id(robot_id)}/driving"


def all_driving(sim: str) -> str:
    """Every chair's drive state."""
    return f"iw/{chunk(sim)}/robot/*/driving"


def alive(sim: str, role: str, name: str) -> str:
    """A process's liveliness token."""
    if role not in ROLES:
        raise ValueError(f"unknown role {role!r}; one of {', '.join(ROLES)}")
    return f"iw/{chunk(sim)}/alive/{role}/{chunk(name)}"


def all_alive(sim: str) -> str:
    """Every liveliness token of a simulation."""
    return f"iw/{chunk(sim)}/alive/**"


def robot_id_of(key: str) -> int | None:
    """The robot id in a per-robot key, or ``None`` for any other key."""
    m = _ROBOT_KEY.match(str(key))
    return int(m.group(1)) if m else None


_TOPICS = {
    ("world", "info"): "info",
    ("world", "register"): "register",
    ("world", "tick"): "tick",
    ("world", "proposed"): "proposed",
    ("world", "verdict"): "verdict",
    ("world", "state"): "state",
    ("world", "control"): "control",
    ("world", "radio"): "radio",
}


_ROBOT_KINDS = ("spec", "actions", "pose_report", "chair", "sensors", "say", "hear", "drive", "driving")


def topic_kind(key: str) -> str | None:
    """What a key carries: ``state``, ``actions``, ``event``... (``None`` for a foreign key).

    The recorder and the replay use it to pick each channel's message type.
    """
    parts = str(key).split("/")
    if len(parts) < 4 or parts[0] != "iw":
        return None
    if len(parts) == 4 and (parts[2], parts[3]) in _TOPICS:
        return _TOPICS[(parts[2], parts[3])]
    if len(parts) == 4 and parts[2] == "events":
        return "event"
    if len(parts) == 5 and parts[2] == "world" and parts[3] == "sensors":
        return "sensor_batch"
    if len(parts) == 5 and parts[2] == "agent" and parts[4] == "actions":
        return "action_batch"
    if len(parts) == 5 and parts[2] == "robot" and parts[3].isdigit():
        return parts[4] if parts[4] in _ROBOT_KINDS else None
    return None


_SUPERSEDED = frozenset({"info", "tick", "proposed", "verdict", "state"})


def superseded(key_expr: str) -> bool:
    """Whether each message on ``key_expr`` supersedes the one before (the world's state, clock,
    proposal, verdict, description): a reader behind needs only the newest few.

    Every other key (actions, events, control, radio, readings) carries messages that each count.
    """
    return topic_kind(key_expr) in _SUPERSEDED


def with_sim(key: str, sim: str) -> str:
    """The same key in another simulation (a replay beside a live run)."""
    parts = str(key).split("/")
    if len(parts) < 2 or parts[0] != "iw":
        raise ValueError(f"{key!r} is not an iw-zenoh key")
    parts[1] = chunk(sim)
    return "/".join(parts)


def sim_of(key: str) -> str | None:
    """The simulation a key belongs to."""
    parts = str(key).split("/")
    return parts[1] if len(parts) > 2 and parts[0] == "iw" else None


def alive_parts(key: str) -> tuple[str, str] | None:
    """``(role, name)`` of a liveliness key, or ``None``."""
    parts = str(key).split("/")
    if len(parts) == 5 and parts[0] == "iw" and parts[2] == "alive":
        return parts[3], parts[4]
    return None


# ROS 2 (rmw_zenoh, Jazzy): keys outside iw/{sim}/, shared with every ROS 2 node on the router
# (docs/ros2.md; iw_zenoh/ros2 builds the names, types and tokens that go in them)


def _ros2_domain(domain_id: int) -> int:
    if isinstance(domain_id, bool) or not isinstance(domain_id, int) or not 0 <= domain_id <= 232:
        raise ValueError(f"ROS_DOMAIN_ID must be an integer in 0..232, got {domain_id!r}")
    return domain_id


def ros2_topic(domain_id: int, topic: str, dds_type: str, type_hash: str) -> str:
    """A ROS 2 topic's data key: ``<domain>/<topic without its leading slash>/<DDS type>/<RIHS01>``."""
    name = topic[1:] if topic.startswith("/") else topic
    for part in name.split("/"):
        chunk(part)  # no empty level, no wildcard
    return f"{_ros2_domain(domain_id)}/{name}/{chunk(dds_type)}/{chunk(type_hash)}"


def ros2_in_every_namespace(domain_id: int, name: str, dds_type: str, type_hash: str) -> str:
    """A topic ``name`` (``odom``) of a type in every namespace of a domain (each chair's odom)."""
    return f"{_ros2_domain(domain_id)}/**/{chunk(name)}/{chunk(dds_type)}/{chunk(type_hash)}"


def ros2_token(domain_id: int, parts: list[str]) -> str:
    """A ROS 2 graph liveliness token: ``@ros2_lv/<domain>/`` and the entity's mangled parts."""
    return f"@ros2_lv/{_ros2_domain(domain_id)}/" + "/".join(chunk(p) for p in parts)


def ros2_all_tokens(domain_id: int) -> str:
    """Every ROS 2 graph token of a domain."""
    return f"@ros2_lv/{_ros2_domain(domain_id)}/**"


def ros2_everything(domain_id: int) -> str:
    """Every ROS 2 topic of a domain."""
    return f"{_ros2_domain(domain_id)}/**"
