"""The board link's frames: round trips, and a decoder that no byte stream can crash or fool."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from iw_zenoh.bridges.serial.protocol import (
    NO_RANGE,
    Clear,
    EStop,
    Frame,
    FrameDecoder,
    Heartbeat,
    Message,
    Motors,
    Status,
    encode_frame,
    power_from_units,
    power_to_units,
)

i16 = st.integers(-1500, 1500)
i32 = st.integers(-(2**31), 2**31 - 1)
u8 = st.integers(0, 255)
u16 = st.integers(0, 0xFFFF)
statuses = st.builds(
    Status,
    ack=u16,
    encoders=st.tuples(i32, i32),
    wheels=st.tuples(i16, i16),
    battery_mv=u16,
    bumpers=u8,
    flags=u8,
    fault=u8,
    ranges_mm=st.lists(u16, max_size=16).map(tuple),
)
messages: st.SearchStrategy[Message] = st.one_of(
    st.builds(Motors, i16, i16), st.just(EStop()), st.just(Clear()), st.just(Heartbeat()), statuses
)


@given(messages, u16)
def test_encode_decode_round_trip(msg: Message, seq: int) -> None:
    data = encode_frame(msg, seq)
    assert data.endswith(b"\x00")
    assert b"\x00" not in data[:-1]
    assert FrameDecoder().feed(data) == [Frame(seq, msg)]


@given(st.lists(messages, min_size=1, max_size=8), st.integers(1, 7))
def test_a_stream_cut_anywhere_decodes_the_same(msgs: list[Message], step: int) -> None:
    data = b"".join(encode_frame(m, i) for i, m in enumerate(msgs))
    d = FrameDecoder()
    got = [f for i in range(0, len(data), step) for f in d.feed(data[i : i + step])]
    assert [f.msg for f in got] == msgs


@settings(max_examples=500)
@given(st.binary(max_size=2000))
def test_arbitrary_bytes_never_raise(data: bytes) -> None:
    d = FrameDecoder()
    d.feed(data)
    d.feed(b"\x00")


@settings(max_examples=500)
@given(messages, u16, st.data())
def test_a_flipped_bit_is_never_accepted(msg: Message, seq: int, data: st.DataObject) -> None:
    frame = bytearray(encode_frame(msg, seq))
    bit = data.draw(st.integers(0, 8 * (len(frame) - 1) - 1))  # any bit but the delimiter's
    frame[bit // 8] ^= 1 << (bit % 8)
    d = FrameDecoder()
    assert d.feed(bytes(frame) + b"\x00") == []
    assert d.stats.dropped_total >= 1


def test_garbage_before_a_frame_is_skipped_and_counted() -> None:
    d = FrameDecoder()
    got = d.feed(b"\x07\x01\x02\x00" + encode_frame(Motors(10, -10), 1))
    assert got == [Frame(1, Motors(10, -10))]
    assert d.stats.dropped_total == 1


def test_a_truncated_frame_is_dropped_and_the_next_one_kept() -> None:
    good = encode_frame(Motors(1, 2), 2)
    d = FrameDecoder()
    got = d.feed(encode_frame(Motors(500, 500), 1)[:5] + b"\x00" + good)
    assert got == [Frame(2, Motors(1, 2))]
    assert d.stats.dropped_total == 1


def test_duplicate_and_older_frames_are_dropped_as_out_of_order() -> None:
    d = FrameDecoder()
    stream = [encode_frame(Motors(i, i), s) for i, s in enumerate([5, 5, 4, 6, 65535])]
    got = d.feed(b"".join(stream))
    assert [f.seq for f in got] == [5, 6]
    assert d.stats.dropped["out-of-order"] == 3


def test_sequence_numbers_wrap() -> None:
    d = FrameDecoder()
    got = d.feed(encode_frame(Heartbeat(), 65535) + encode_frame(Heartbeat(), 0))
    assert [f.seq for f in got] == [65535, 0]


def test_resync_accepts_a_restarted_peer() -> None:
    d = FrameDecoder()
    d.feed(encode_frame(Heartbeat(), 900))
    d.resync()
    assert [f.seq for f in d.feed(encode_frame(Heartbeat(), 0))] == [0]


def test_an_endless_frame_is_dropped_as_oversized() -> None:
    d = FrameDecoder()
    assert d.feed(b"\x01" * 5000 + b"\x00" + encode_frame(Clear(), 1)) == [Frame(1, Clear())]
    assert d.stats.dropped == {"oversized": 1}


def test_another_version_is_dropped() -> None:
    import binascii

    from cobs import cobs

    body = bytes([2, 0x04, 1, 0, 0])
    body += binascii.crc_hqx(body, 0xFFFF).to_bytes(2, "big")
    d = FrameDecoder()
    assert d.feed(cobs.encode(body) + b"\x00") == []
    assert d.stats.dropped == {"version": 1}


def test_power_units_clamp_and_round_trip() -> None:
    assert power_to_units(0.15) == 1500
    assert power_to_units(0.9) == 1500
    assert power_to_units(-0.2) == -1500
    assert power_from_units(power_to_units(0.0731)) == 0.0731
    assert NO_RANGE == 0xFFFF
