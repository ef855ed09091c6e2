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
        (keys.radio("s"), keys.everything("s")),
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
