from __future__ import annotations

import pytest
import zenoh

from iw_zenoh import keys


@pytest.mark.parametrize(
    ("key", "pattern"),
    [
        (keys.actions("s", 3), keys.all_actions("s")),
        (keys.sensors("s", 3), keys.all_sensors("s")),
        (keys.say("s", 3), keys.all_say("s")),
        (keys.hear("s", 3), keys.all_hear("s")),
        (keys.pose_report("s", 3), keys.all_pose_reports("s")),
        (keys.event("s", "collision"), keys.all_events("s")),
        (keys.alive("s", "agent", "a1"), keys.all_alive("s")),
        (keys.state("s"), keys.everything("s")),
        (keys.spec("s", 1), keys.everything("s")),
        (keys.spec("s", 1), keys.all_specs("s")),
        (keys.chair("s", 1), keys.all_chairs("s")),
        (keys.radio("s"), keys.everything("s")),
        (keys.sensor_batch("s", (2, 3)), keys.all_sensor_batches("s")),
        (keys.agent_actions("s", "host1"), keys.all_agent_actions("s")),
        (keys.drive("s", 3), keys.all_drive("s")),
        (keys.driving("s", 3), keys.all_driving("s")),
    ],
)
def test_every_builder_matches_its_pattern(key: str, pattern: str) -> None:
    assert zenoh.KeyExpr(pattern).intersects(zenoh.KeyExpr(key))


def test_simulations_do_not_see_each_other() -> None:
    assert not zenoh.KeyExpr(keys.everything("a")).intersects(zenoh.KeyExpr(keys.state("b")))


@pytest.mark.parametrize("bad", ["", "a/b", "a*", "$x", "a b", "q?"])
def test_bad_chunks_are_refused(bad: str) -> None:
    with pytest.raises(ValueError, match="not a valid key chunk"):
        keys.state(bad)


def test_robot_ids_are_checked_and_read_back() -> None:
    with pytest.raises(ValueError, match="non-negative"):
        keys.actions("s", -1)
    assert keys.robot_id_of(keys.actions("s", 42)) == 42
    assert keys.robot_id_of(keys.state("s")) is None
    assert keys.alive_parts(keys.alive("s", "collision", "c1")) == ("collision", "c1")


def test_batched_keys_say_what_they_carry() -> None:
    assert keys.sensor_batch("s", (2, 3)) == "iw/s/world/sensors/2-3"
    with pytest.raises(ValueError, match="1 <= K <= N"):
        keys.sensor_batch("s", (4, 3))
    assert keys.topic_kind(keys.sensor_batch("s", (1, 1))) == "sensor_batch"
    assert keys.topic_kind(keys.agent_actions("s", "h")) == "action_batch"
    assert keys.agent_of(keys.agent_actions("s", "h")) == "h"
    assert keys.agent_of(keys.actions("s", 1)) is None
    # a batch is not mistaken for a robot's own key
    assert keys.robot_id_of(keys.sensor_batch("s", (1, 1))) is None


def test_a_control_key_is_known_whatever_the_simulation() -> None:
    assert keys.is_control(keys.control("demo"))
    assert keys.is_control(keys.control("hospital"))
    assert not keys.is_control(keys.state("demo"))
    assert not keys.is_control("iw/demo/robot/1/world/control")


def test_the_drive_keys_carry_the_drive_protocol() -> None:
    from iw_zenoh.messages import TOPIC_TYPES, DriveInput, DriveState

    assert keys.drive("s", 2) == "iw/s/robot/2/drive"
    assert keys.driving("s", 2) == "iw/s/robot/2/driving"
    assert keys.robot_id_of(keys.drive("s", 2)) == 2
    assert TOPIC_TYPES[keys.topic_kind(keys.drive("s", 2)) or ""] is DriveInput
    assert TOPIC_TYPES[keys.topic_kind(keys.driving("s", 2)) or ""] is DriveState
    assert not zenoh.KeyExpr(keys.all_drive("s")).intersects(zenoh.KeyExpr(keys.driving("s", 1)))
