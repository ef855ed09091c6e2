from __future__ import annotations

import io
from pathlib import Path

import pytest

from iw_zenoh import keys
from iw_zenoh.errors import IwError, RecordingError
from iw_zenoh.messages import Actions, Event, WorldState, encode
from iw_zenoh.record.reader import BadMessage, KeyFilter, RecordingReader, Window, open_recording
from iw_zenoh.record.recording import Recorder
from tests.support.recordings import recorded_state as _state

SAMPLE = Path(__file__).resolve().parents[2] / "recordings" / "demo-sample.mcap"


def _recording(ticks: int = 20) -> io.BytesIO:
    buf = io.BytesIO()
    rec = Recorder(buf, chunk_size=2000, scene=False)
    for t in range(1, ticks + 1):
        at = 1_000_000_000 + t * 100_000_000
        rec.add(keys.state("s"), _state(t), at)
        rec.add(keys.actions("s", 1), encode(Actions(tick=t, sim_time_ns=t * 100_000_000, robot_id=1)), at + 5)
    rec.add(keys.event("s", "bad-message"), b"{not json", 9_000_000_000)
    rec.add(keys.event("s", "collision"), encode(Event(kind="collision", robot_id=1, reason="wall")), 9_000_000_001)
    rec.finish()
    buf.seek(0)
    return buf


def test_records_are_decoded_by_kind_in_log_time_order() -> None:
    got = list(RecordingReader(_recording()).records(("state",)))
    assert [r.message.tick for r in got if isinstance(r.message, WorldState)] == list(range(1, 21))
    assert {r.topic for r in got} == {keys.state("s")}
    assert all(r.kind == "state" and r.publish_time == r.message.sim_time_ns for r in got)
    logs = [r.log_time for r in got]
    assert logs == sorted(logs)


def test_a_payload_that_does_not_decode_is_reported_and_skipped() -> None:
    bad: list[BadMessage] = []
    reader = RecordingReader(_recording(), on_bad=bad.append)
    events = [r.message for r in reader.records(("event",))]
    assert [type(m) for m in events] == [Event]
    assert [b.topic for b in bad] == [keys.event("s", "bad-message")]
    assert bad[0].reason
    assert reader.bad == {keys.event("s", "bad-message"): 1}


def test_raw_gives_every_payload_byte_for_byte_including_malformed_ones() -> None:
    raw = list(RecordingReader(_recording()).raw(("event",)))
    assert [r.data for r in raw][0] == b"{not json"
    assert len(raw) == 2


def test_key_expressions_and_a_simulation_time_window_filter() -> None:
    reader = RecordingReader(_recording())
    acts = list(reader.records(topics=KeyFilter(("iw/*/robot/*/actions",)), window=Window(sim_start=5 * 10**8)))
    assert [r.message.tick for r in acts if isinstance(r.message, Actions)] == list(range(5, 21))
    late = list(reader.raw(("state",), window=Window(log_start=1_000_000_000 + 15 * 100_000_000, sim_end=17 * 10**8)))
    assert [r.publish_time // 100_000_000 for r in late] == [15, 16, 17]


def test_a_key_filter_passes_foxglove_topics_only_without_patterns() -> None:
    assert KeyFilter()("/foxglove/scene")
    assert not KeyFilter(("iw/**",))("/foxglove/scene")
    assert KeyFilter((), ("iw/*/world/state",))("/foxglove/scene")
    assert not KeyFilter((), ("iw/*/world/state",))(keys.state("s"))
    with pytest.raises(IwError, match="not a Zenoh key expression"):
        KeyFilter(("iw//x",))


def test_the_sample_recording_decodes_and_holds_derived_channels() -> None:
    with open_recording(SAMPLE) as reader:
        kinds = {r.kind for r in reader.raw()}
        decoded = sum(1 for _ in reader.records())
        assert reader.bad == {}
    assert None in kinds  # the Foxglove scene channels
    assert decoded > 1000


@pytest.mark.parametrize(
    ("content", "reason"),
    [(b"not an mcap file at all", "not an MCAP file"), (b"\x89MCAP0\r\n\x01\x02", "cut off after 10 bytes")],
)
def test_a_file_that_is_not_a_readable_recording_is_named_with_the_reason(
    tmp_path: Path, content: bytes, reason: str
) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(content)
    with pytest.raises(RecordingError) as e, open_recording(bad) as reader:
        list(reader.raw())
    assert str(e.value).startswith(f"{bad}: ")
    assert reason in str(e.value)
    assert len(e.value.reason) > 3


def test_a_missing_file_is_named_with_the_reason(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match=r"nope\.mcap: No such file"), open_recording(tmp_path / "nope.mcap"):
        pass
