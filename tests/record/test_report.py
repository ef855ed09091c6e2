"""``iwz report`` on a run whose answers are known by construction: a recording written with the
project's own Recorder of a chair that rests 1 s, accelerates at 0.5 m/s2 for 1 s, cruises at
0.5 m/s for 8 s, brakes at 0.5 m/s2 for 1 s and waits 2 s beside a door; a second chair stands
still above its path. And hostile files: cut off, garbage, empty of states."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.cli import main as iwz
from iw_zenoh.convert import lab_to_msg, spec_to_msg
from iw_zenoh.core.lab import Lab
from iw_zenoh.core.spec import RobotSpec, RobotType
from iw_zenoh.messages import EventKind, WorldInfo, WorldState, encode, make_event
from iw_zenoh.record.metrics import Goal, parse_goals
from iw_zenoh.record.recording import Recorder
from iw_zenoh.record.report import report_of

SIM = "s"
TICK_NS = 100_000_000
CHAIR = RobotSpec("walker", id=1, width_m=1.0, height_m=0.6, com=0.5)
STILL = RobotSpec("still", id=2, width_m=1.0, height_m=0.6, com=0.5)
DOOR = RobotSpec("door", id=3, type=RobotType.DOOR, width_m=0.1, height_m=1.0, com=0.5)


def _x(k: int) -> float:
    """The walker's x at tick k (exact at every tick: k / 10 is exact for these k)."""
    t = k / 10 - 1.0  # it rests for the first second
    if t <= 0:
        return 2.0
    if t <= 1:
        return 2.0 + 0.25 * t * t
    if t <= 9:
        return 2.25 + 0.5 * (t - 1)
    if t <= 10:
        u = t - 9
        return 6.25 + 0.5 * u - 0.25 * u * u
    return 6.5


def _record(path: Path, *, goals: str = "1=6.5,5,0.52") -> None:
    info = WorldInfo(
        revision=1,
        lab=lab_to_msg(Lab("hall", 20.0, 10.0)),
        period_ns=TICK_NS,
        robots=[spec_to_msg(s) for s in (CHAIR, STILL, DOOR)],
    )
    with path.open("wb") as f:
        rec = Recorder(f, {"iw.user": {"scenario": "straight", "goals": goals}}, scene=False)
        rec.add(keys.info(SIM), encode(info), 1)
        for k in range(0, 131):  # 13 s: rest 1, drive 10, wait 2
            st = WorldState(
                tick=k,
                sim_time_ns=k * TICK_NS,
                revision=1,
                ids=[1, 2, 3],
                x=[_x(k), 4.0, 7.8],
                y=[5.0, 7.0, 5.0],
                heading=[0.0, 0.0, 0.0],
                collided=[50 <= k <= 52, False, False],  # one contact, three ticks long
                rolled_left=[0.0] * 3,
                rolled_right=[0.0] * 3,
                speed=[0.0] * 3,
            )
            rec.add(keys.state(SIM), encode(st), 10 + k)
            if k == 60:
                ev = make_event(EventKind.WATCHDOG, reason="no actions", tick=k, sim_time_ns=k * TICK_NS, robot_id=1)
                rec.add(keys.event(SIM, "watchdog"), encode(ev), 10 + k)
        rec.finish()


def test_a_straight_drive_reads_its_known_figures(tmp_path: Path) -> None:
    path = tmp_path / "straight.mcap"
    _record(path)
    r = report_of(path)
    assert r.ticks == 131
    assert r.duration_s == pytest.approx(13.0)
    walker, still = r.chairs  # the door is no chair
    assert (walker.robot_id, still.robot_id) == (1, 2)
    assert walker.path_length_m == pytest.approx(4.5)
    assert walker.time_to_goal_s == pytest.approx(9.5)  # within 0.52 of x = 6.5 at x = 6.0, t = 9.5 s
    assert walker.time_to_stop_s == pytest.approx(11.0)
    assert walker.mean_speed_mps == pytest.approx(0.45)  # 4.5 m over the 10 s it moved
    assert walker.peak_speed_mps == pytest.approx(0.5)
    assert walker.peak_accel_mps2 == pytest.approx(0.5)
    assert walker.peak_jerk_mps3 == pytest.approx(2.5)  # 0 -> 0.25 -> 0.5 m/s2 over 0.1 s steps
    assert walker.min_clearance_walls_m == pytest.approx(0.75)  # its nose 0.75 m from the door leaf
    assert walker.min_clearance_people_m == pytest.approx(1.4)  # passing under the still chair
    assert walker.collisions == 1
    assert walker.near_misses == 0
    assert walker.watchdog_stops == 1
    assert walker.door_wait_s == pytest.approx(2.0)
    assert still.path_length_m == 0.0
    assert still.time_to_stop_s is None
    assert still.time_to_goal_s is None
    assert r.run["collisions"] == 1
    assert r.run["goals_reached"] == 1
    assert r.run["time_to_last_goal_s"] == pytest.approx(9.5)


def test_a_goal_not_reached_and_one_given_on_the_command_line(tmp_path: Path) -> None:
    path = tmp_path / "straight.mcap"
    _record(path, goals="1=15,5")
    assert report_of(path).chairs[0].time_to_goal_s is None
    assert report_of(path, {1: Goal(4.25, 5.0, 0.01)}).chairs[0].time_to_goal_s == pytest.approx(6.0)


def test_the_command_prints_a_table_json_and_a_self_contained_page_for_two_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    _record(a)
    _record(b, goals="")
    assert iwz(["report", str(a)]) == 0
    text = capsys.readouterr().out
    assert re.search(r"path length, m\s+4\.50", text)
    assert "chair 1 (walker)" in text
    assert iwz(["report", str(a), str(b), "--json"]) == 0
    runs = json.loads(capsys.readouterr().out)["runs"]
    assert [run["file"] for run in runs] == [str(a), str(b)]
    assert runs[0]["chairs"][0]["time_to_goal_s"] == pytest.approx(9.5)
    assert runs[1]["chairs"][0]["time_to_goal_s"] is None
    page = tmp_path / "cmp.html"
    assert iwz(["report", str(a), str(b), "--html", str(page)]) == 0
    html = page.read_text()
    assert html.count("data:image/png;base64,") == 4  # paths and time plots, for each run
    assert "http://" not in html
    assert "https://" not in html
    assert "a.mcap" in html
    assert "b.mcap" in html


@pytest.mark.parametrize(
    ("content", "why"),
    [
        (b"", "empty"),
        (b"not an mcap file at all" * 10, "garbage"),
        (None, "cut off"),
    ],
)
def test_a_broken_file_is_refused_with_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: bytes | None, why: str
) -> None:
    path = tmp_path / f"{why.replace(' ', '-')}.mcap"
    if content is None:
        _record(path)
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    else:
        path.write_bytes(content)
    assert iwz(["report", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"iwz report: {path}")
    assert "Traceback" not in err


def test_a_recording_without_world_states_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "quiet.mcap"
    with path.open("wb") as f:
        rec = Recorder(f, scene=False)
        rec.finish()
    assert iwz(["report", str(path)]) == 2
    assert "no world state" in capsys.readouterr().err


def test_a_missing_file_and_a_bad_goal_are_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert iwz(["report", str(tmp_path / "nope.mcap")]) == 2
    assert "nope.mcap" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        iwz(["report", str(tmp_path / "nope.mcap"), "--goal", "1=a,b"])
    assert "--goal: goal '1=a,b' is not ID=X,Y[,WITHIN]" in capsys.readouterr().err


def test_goals_parse_and_refuse() -> None:
    assert parse_goals("1=2,3;4=5,6,0.2") == {1: Goal(2.0, 3.0, 0.5), 4: Goal(5.0, 6.0, 0.2)}
    assert parse_goals("") == {}
    for bad in ("1=2", "x=1,2", "1=1,2,-1", "-1=1,2", "1=nan,2"):
        with pytest.raises(ValueError, match="ID=X,Y"):
            parse_goals(bad)


@pytest.mark.parametrize("near", ["-1", "0", "nan", "inf", "close"])
@pytest.mark.parametrize("command", ["report", "incidents"])
def test_a_near_miss_clearance_that_is_no_positive_number_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], near: str, command: str
) -> None:
    path = tmp_path / "a.mcap"
    _record(path)
    with pytest.raises(SystemExit) as e:
        iwz([command, str(path), "--near", near])
    assert e.value.code == 2
    assert f"--near: a clearance is a positive number of metres, e.g. 0.3; got {near!r}" in capsys.readouterr().err


def test_a_page_that_cannot_be_written_is_named_without_a_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "a.mcap"
    _record(path)
    out = tmp_path / "no-such-folder" / "page.html"
    assert iwz(["report", str(path), "--html", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"iwz report: --html {out}: cannot write it" in err
    assert "Traceback" not in err


def test_a_file_of_only_the_mcap_magic_is_a_recording_cut_off_at_its_start(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "started.mcap"
    path.write_bytes(b"\x89MCAP0\r\n")  # a recorder killed right after it opened the file
    assert iwz(["report", str(path)]) == 2
    assert "cut off after 8 bytes (a crash, or still being written): iwz recover rebuilds it" in capsys.readouterr().err
