"""A recording in numbered parts (a restarted recorder's): naming, continuing, and every reader
reading the parts as one, a cut-off part included (as far as it goes, or from its recovered copy)."""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import msgspec
import pytest

from iw_zenoh import keys
from iw_zenoh.errors import RecordingError
from iw_zenoh.launch.launcher import Launcher
from iw_zenoh.messages import Event, EventKind, WorldState, decode, encode
from iw_zenoh.nodes.role_options import RecorderOptions
from iw_zenoh.nodes.role_options import add_recorder_arguments as recorder_arguments
from iw_zenoh.process.options import options_from_args
from iw_zenoh.record.incidents import find_incidents
from iw_zenoh.record.parts import (
    PART_META,
    first_part,
    head_metadata,
    next_part,
    part_number,
    part_path,
    recording_parts,
)
from iw_zenoh.record.reader import open_recording
from iw_zenoh.record.recording import SIM_INDEX, Recorder
from iw_zenoh.record.replay import Player, ReplayOptions, sim_index
from iw_zenoh.record.tools import check_recording, doctor_main, recover_main
from iw_zenoh.scenario.file import load_scenario
from tests.record.test_recording import _state

T0 = 1_000_000_000
MAPS = Path(__file__).resolve().parents[2] / "maps"


def _part(first: Path, ticks: range, *, run: str | None, cut: bool = False) -> Path:
    """Writes the next part as the recorder does (ticks 100 ms apart); ``cut``: killed mid-chunk."""
    path, part, user = next_part(first, run)
    meta = {PART_META: part, "iw.user": user or {"scenario": "unit", "seed": "7"}}
    f = path.open("wb")
    rec = Recorder(f, meta, chunk_size=1500, scene=False)
    for t in ticks:
        at = T0 + t * 100_000_000
        rec.add(keys.state("s"), _state(t), at)
        if t % 10 == 5:
            rec.add(
                keys.event("s", "collision"),
                encode(Event(kind=EventKind.COLLISION, robot_id=1, reason="wall", sim_time_ns=t * 10**8)),
                at + 1,
            )
    if cut:
        rec.flush()
        f.flush()
        size = f.tell()
        f.close()
        path.write_bytes(path.read_bytes()[: size - 300])  # the last chunk half written
    else:
        rec.finish()
        f.close()
    return path


def test_parts_are_named_after_the_first_and_found_from_any_of_them(tmp_path: Path) -> None:
    first = tmp_path / "run.mcap"
    assert part_path(first, 1) == first
    assert part_path(first, 2) == tmp_path / "run.part2.mcap"
    assert part_number(tmp_path / "run.part12.mcap") == 12
    assert part_number(first) == part_number(tmp_path / "run.part1.mcap") == 1
    assert first_part(tmp_path / "run.part3.mcap") == first
    for name in ("run.mcap", "run.part2.mcap", "run.part10.mcap", "run.part3.mcap", "run.part2.recovered.mcap"):
        (tmp_path / name).write_bytes(b"")
    (tmp_path / "other.part2.mcap").write_bytes(b"")
    want = [first, tmp_path / "run.part2.mcap", tmp_path / "run.part3.mcap", tmp_path / "run.part10.mcap"]
    assert recording_parts(tmp_path / "run.part3.mcap") == recording_parts(first) == want
    assert recording_parts(tmp_path / "alone.mcap") == [tmp_path / "alone.mcap"]


def test_a_continued_recording_gets_the_next_part_with_its_metadata(tmp_path: Path) -> None:
    first = tmp_path / "run.mcap"
    _part(first, range(1, 11), run="abc")
    path, part, user = next_part(first, "abc")
    assert path == tmp_path / "run.part2.mcap"
    assert part == {"part": "2", "recording": "abc", "previous": "run.mcap"}
    assert user == {"scenario": "unit", "seed": "7"}
    assert next_part(first, "")[0] == path  # any recording there
    _part(first, range(11, 21), run="abc")
    with (tmp_path / "run.part2.mcap").open("rb") as f:
        assert head_metadata(f)[PART_META]["part"] == "2"
    # another run (another id), or no --continue: afresh, the old parts removed
    path, part, _ = next_part(first, "xyz")
    assert (path, part["part"], part["recording"]) == (first, "1", "xyz")
    assert not (tmp_path / "run.part2.mcap").exists()


def _three_parts(tmp_path: Path) -> Path:
    first = tmp_path / "run.mcap"
    _part(first, range(1, 31), run="r")
    _part(first, range(40, 71), run="r", cut=True)  # killed: 0.9 s lost before the restart
    _part(first, range(80, 101), run="r")
    return first


def test_every_part_reads_as_one_recording_a_cut_off_part_as_far_as_it_goes(tmp_path: Path) -> None:
    first = _three_parts(tmp_path)
    with open_recording(tmp_path / "run.part3.mcap") as rec:
        ticks = [r.message.tick for r in rec.records(("state",)) if isinstance(r.message, WorldState)]
        assert ticks == sorted(ticks)
        assert ticks[:30] == list(range(1, 31))
        assert ticks[-21:] == list(range(80, 101))
        assert 40 in ticks
        assert 70 not in ticks
        notes = "\n".join(rec.notes)
        assert "run.part2.mcap is cut off" in notes
        assert "iwz recover" in notes
        assert "the rest is lost" in notes
        assert "s of log time not recorded between" in notes
        assert str(first) in notes
        assert rec.metadata()["iw.user"]["scenario"] == "unit"
        assert len(rec.metadata()[SIM_INDEX]) >= 5  # the parts' indexes merged
        assert rec.progress() == 1.0
    with open_recording(first) as rec:
        sims, logs, sim = sim_index(rec)
        assert 45 * 100_000_000 in sims  # the cut-off part's states are found (by a scan: it has no index)
        assert logs == sorted(logs)
        assert sim == "s"
        assert sims == sorted(sims)
        assert sims[-1] >= 80 * 100_000_000
        hits = [i.t for i in find_incidents(rec) if i.kind == "collision"]
        assert 0.5 in hits
        assert 9.5 in hits


def test_a_recording_of_one_cut_off_file_is_still_refused(tmp_path: Path) -> None:
    path = _part(tmp_path / "one.mcap", range(1, 40), run=None, cut=True)
    with pytest.raises(RecordingError, match="cut off"), open_recording(path):
        pass


def test_doctor_names_the_cut_off_part_and_recover_mends_it_for_every_reader(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = _three_parts(tmp_path)
    found = check_recording(first)
    assert [(h.part, h.whole) for h in found] == [(1, True), (2, False), (3, True)]
    assert doctor_main([str(first)]) == 1
    out = capsys.readouterr().out
    assert "run.part2.mcap (part 2 of 3): NOT whole" in out
    assert "cut off" in out
    assert f"iwz recover {tmp_path / 'run.part2.mcap'}" in out
    assert "(part 1 of 3): whole" in out
    assert "(part 3 of 3): whole" in out
    assert recover_main([str(tmp_path / "run.part2.mcap")]) == 0
    assert (tmp_path / "run.part2.recovered.mcap").exists()
    assert doctor_main([str(first)]) == 0
    assert "its recovered copy" in capsys.readouterr().out
    with open_recording(first) as rec:
        ticks = [r.message.tick for r in rec.records(("state",)) if isinstance(r.message, WorldState)]
        assert "read from its recovered copy" in rec.notes[0]
    assert ticks == sorted(ticks)
    assert 40 in ticks
    assert 100 in ticks


def test_a_stream_is_one_part(tmp_path: Path) -> None:
    path = _part(tmp_path / "s.mcap", range(1, 5), run=None)
    with open_recording(io.BytesIO(path.read_bytes())) as rec:
        assert len(rec.parts) == 1
        assert not rec.notes
        assert sum(1 for _ in rec.raw()) == 4


class _Served:
    def poll(self) -> list[object]:
        return []


class _Bus:
    """Just what a player uses: it publishes, hears controls, answers info queries."""

    def __init__(self) -> None:
        self.sent: list[tuple[str, bytes]] = []

    def publish(self, key: str, data: bytes) -> None:
        self.sent.append((key, data))

    def subscribe(self, key_expr: str, inbox: object) -> None:
        pass

    def serve(self, key: str) -> _Served:
        return _Served()


def test_a_player_plays_every_part_and_says_how_far_it_is(tmp_path: Path) -> None:
    first = _three_parts(tmp_path)
    bus = _Bus()
    seen: list[float] = []
    with open_recording(first) as rec:
        player = Player(rec, bus, ReplayOptions(rate=0))  # type: ignore[arg-type]
        player.progress = lambda fraction, _detail: seen.append(fraction)
        player.run()
    ticks = [decode(d, WorldState).tick for k, d in bus.sent if keys.topic_kind(k) == "state"]
    assert ticks[:30] == list(range(1, 31))
    assert ticks[-1] == 100
    assert len(seen) == len(ticks)
    assert seen == sorted(seen)
    assert seen[-1] > 0.5


def test_the_launcher_starts_its_recorder_to_continue_this_run_when_restarted(tmp_path: Path) -> None:
    launcher = Launcher(
        load_scenario(MAPS / "scenarios" / "demo.toml"),
        port=7999,
        log_dir=tmp_path,
        status=False,
        record=tmp_path / "r.mcap",
    )
    launcher.plan()
    argv = next(c for c in launcher.children if c.role == "record").argv
    run = msgspec.json.decode(argv[argv.index("--options") + 1], type=RecorderOptions).continue_run
    assert run is not None
    assert len(run) == 32
    p = argparse.ArgumentParser()
    recorder_arguments(p)
    assert options_from_args(p.parse_args(["--continue", run]), RecorderOptions).continue_run == run
    assert options_from_args(p.parse_args(["--continue"]), RecorderOptions).continue_run == ""
    assert options_from_args(p.parse_args([]), RecorderOptions).continue_run is None
