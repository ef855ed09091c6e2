"""Damaged copies of a real recording (flipped bits, truncations, zeroed ranges, swapped chunks,
seeded) through ``iwz recover`` and every reader: recover never makes a file doctor calls whole
holding a message that was not recorded (a chunk whose CRC fails is dropped whole, and said so);
doctor never calls a damaged file whole when its messages differ; doctor, incidents, report,
render and resim refuse a damaged file (or read it with a note), in words, never an exception's
name. The 200-case sweep is ``python -m benchmarks.damaged_recordings``."""

from __future__ import annotations

from pathlib import Path

import pytest

from iw_zenoh.errors import RecordingError
from iw_zenoh.record.reader import open_recording
from iw_zenoh.record.tools import check, recover_main
from tests.support.damage import KINDS, damaged, judge, messages, small_recording

CASES = [(kind, seed) for kind in KINDS for seed in range(6)]


@pytest.fixture(scope="module")
def original(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("corpus") / "original.mcap"
    path.write_bytes(small_recording())
    assert check(path).whole
    return path


@pytest.mark.parametrize(("kind", "seed"), CASES)
def test_a_damaged_copy_is_never_laundered_nor_read_in_silence(
    original: Path, tmp_path: Path, kind: str, seed: int
) -> None:
    data = damaged(original.read_bytes(), kind, seed)
    assert judge(original, data, tmp_path) == []


def test_recover_drops_a_chunk_whose_crc_fails_whole_and_says_so(
    original: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = bytearray(original.read_bytes())
    with open_recording(original) as rec:
        summary = rec.summary()
    assert summary is not None
    c = summary.chunk_indexes[3]
    data[c.chunk_start_offset + c.chunk_length - 40] ^= 0x10  # inside the chunk's compressed records
    bad, fixed = tmp_path / "bad.mcap", tmp_path / "fixed.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(RecordingError, match="checksum does not match"), open_recording(bad):
        pass
    assert recover_main([str(bad), "-o", str(fixed)]) == 0
    said = capsys.readouterr().out
    assert "dropped whole: 1 damaged chunks" in said
    got, want = messages(fixed), messages(original)
    assert not got - want
    assert 0 < sum((want - got).values()) < sum(want.values()) // 4  # the dropped chunk's messages, only
    assert check(fixed).whole
