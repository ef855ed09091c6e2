"""``iwz doctor`` says when a recording (or one of its parts) holds no world description."""

from __future__ import annotations

from pathlib import Path

from iw_zenoh import keys
from iw_zenoh.convert import lab_to_msg
from iw_zenoh.core.lab import Lab
from iw_zenoh.messages import WorldInfo, WorldState, encode
from iw_zenoh.record.recording import Recorder
from iw_zenoh.record.tools import check

STATE = WorldState(
    tick=1,
    sim_time_ns=100_000_000,
    revision=1,
    ids=[1],
    x=[1.0],
    y=[2.0],
    heading=[0.0],
    collided=[False],
    rolled_left=[0.0],
    rolled_right=[0.0],
    speed=[0.0],
)
INFO = WorldInfo(revision=1, lab=lab_to_msg(Lab("l", 10.0, 10.0)), period_ns=100_000_000)


def _recording(path: Path, *, described: bool) -> Path:
    with path.open("wb") as f:
        rec = Recorder(f)
        if described:
            rec.add(keys.info("s"), encode(INFO), 1)
        rec.add(keys.state("s"), encode(STATE), 2)
        rec.finish()
    return path


def test_doctor_says_a_recording_holds_no_world_description(tmp_path: Path) -> None:
    h = check(_recording(tmp_path / "late.mcap", described=False))
    assert h.whole
    assert h.described is False
    assert any("holds no world description (world/info)" in line for line in h.lines())


def test_doctor_says_nothing_of_it_when_the_description_is_there(tmp_path: Path) -> None:
    h = check(_recording(tmp_path / "run.mcap", described=True))
    assert h.described is True
    assert not any("world description" in line for line in h.lines())
