"""doctor finds damage anywhere in a file; recover refuses what is not MCAP; file errors name the
file and the reason; output cut off by a closed pipe ends quietly."""

from __future__ import annotations

import io
import random
import subprocess
import sys
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.messages import Actions, Event, encode
from iw_zenoh.record.recording import Recorder
from iw_zenoh.record.tools import check, doctor_main, recover_main

SAMPLE = Path(__file__).resolve().parents[2] / "recordings" / "demo-sample.mcap"


def _corrupt(src: Path, dst: Path, at: float, n_bytes: int = 2048, seed: int = 7) -> None:
    data = bytearray(src.read_bytes())
    start = int(len(data) * at)
    data[start : start + n_bytes] = random.Random(seed).randbytes(n_bytes)
    dst.write_bytes(bytes(data))


@pytest.mark.parametrize("at", [0.3, 0.5, 0.7])
def test_doctor_never_calls_a_file_with_2_kb_corrupted_in_its_middle_whole(tmp_path: Path, at: float) -> None:
    bad = tmp_path / "bad.mcap"
    _corrupt(SAMPLE, bad, at)
    h = check(bad)
    assert not h.whole
    assert "damaged" in h.reason


def test_doctor_finds_any_single_damaged_byte_of_a_fresh_recording(tmp_path: Path) -> None:
    buf = io.BytesIO()
    rec = Recorder(buf, {"iw.scenario": {"name": "unit"}}, chunk_size=1500)
    for t in range(1, 60):
        rec.add(keys.actions("s", 1), encode(Actions(tick=t, robot_id=1, left=0.1)), 10**9 + t)
    rec.finish()
    data = buf.getvalue()
    path = tmp_path / "r.mcap"
    path.write_bytes(data)
    assert check(path).whole
    missed = []
    for i in range(8, len(data) - 8, 11):  # every eleventh byte: headers, chunks, indexes, metadata, summary
        flipped = bytearray(data)
        flipped[i] ^= 0x5A
        path.write_bytes(bytes(flipped))
        if check(path).whole:
            missed.append(i)
    assert missed == []


def test_doctor_counts_payloads_recorded_malformed_without_calling_the_file_damaged(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    with path.open("wb") as f:
        rec = Recorder(f)
        rec.add(keys.event("s", "bad-message"), b"{not json", 1)
        rec.add(keys.actions("s", 1), encode(Actions(tick=1, robot_id=1)), 2)
        rec.finish()
    h = check(path)
    assert h.whole
    assert h.undecodable == 1
    assert any("1 messages do not decode" in line for line in h.lines())


def test_recover_refuses_a_file_that_is_not_mcap_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(random.Random(1).randbytes(5000))
    out = tmp_path / "out.mcap"
    assert recover_main([str(junk), "-o", str(out)]) != 0
    said = capsys.readouterr().out
    assert str(junk) in said
    assert "not an MCAP file" in said
    assert not out.exists()


def test_recover_of_an_mcap_start_with_nothing_after_it_says_nothing_was_saved(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"\x89MCAP0\r\n" + random.Random(2).randbytes(3000))
    assert recover_main([str(junk), "-o", str(tmp_path / "out.mcap")]) != 0
    said = capsys.readouterr().out
    assert str(junk) in said
    assert "nothing" in said


@pytest.mark.parametrize(
    "content", [b"", b"x", b"not an mcap file at all", b"\x89MCAP0\r\n\x01\x02", b"\x89MCAP0\r\n" * 3]
)
@pytest.mark.parametrize("tool", ["doctor", "recover", "incidents", "render", "resim"])
def test_every_file_error_names_the_file_and_the_reason(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: bytes, tool: str
) -> None:
    from iw_zenoh import cli

    bad = tmp_path / "bad.mcap"
    bad.write_bytes(content)
    extra = {"render": ["--at", "1", "-o", str(tmp_path / "x.png")], "recover": ["-o", str(tmp_path / "o.mcap")]}
    assert cli.main([tool, str(bad), *extra.get(tool, [])]) != 0
    said = capsys.readouterr().out
    line = next(ln for ln in said.splitlines() if str(bad) in ln)
    reason = line.split(str(bad), 1)[1].strip(" :;")
    assert len(reason) > 10, said
    assert "Errno" not in said


@pytest.mark.parametrize("tool", ["doctor", "incidents", "render", "resim"])
def test_a_missing_file_is_named_with_the_reason(tmp_path: Path, capsys: pytest.CaptureFixture[str], tool: str) -> None:
    from iw_zenoh import cli

    gone = tmp_path / "gone.mcap"
    extra = ["--at", "1", "-o", str(tmp_path / "x.png")] if tool == "render" else []
    assert cli.main([tool, str(gone), *extra]) != 0
    said = capsys.readouterr().out
    assert f"{gone}: No such file or directory" in said or f"{gone}: NOT whole: unreadable: No such file" in said


def test_doctor_main_exits_1_for_a_damaged_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.mcap"
    _corrupt(SAMPLE, bad, 0.5)
    assert doctor_main([str(bad)]) == 1


def test_output_to_a_closed_pipe_ends_quietly(tmp_path: Path) -> None:
    many = tmp_path / "many.mcap"
    with many.open("wb") as f:
        rec = Recorder(f)
        for i in range(4000):  # far more lines than a pipe holds
            ev = Event(tick=i, sim_time_ns=i * 10**8, kind="watchdog", robot_id=1, reason="no actions for 1 s")
            rec.add(keys.event("s", "watchdog"), encode(ev), 10**9 + i)
        rec.finish()
    cmd = [sys.executable, "-m", "iw_zenoh.cli", "incidents", str(many)]
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE) as p:
        assert p.stdout is not None
        assert p.stderr is not None
        assert p.stdout.readline().startswith(b"t=")
        p.stdout.close()  # as `| head -1` does
        err = p.stderr.read().decode()
        assert p.wait(60) != 0
    assert err == ""
