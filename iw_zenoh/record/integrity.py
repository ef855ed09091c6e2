"""Whether a recording's bytes are intact, record by record.

``iwz doctor`` reads the whole file in order: every chunk is decompressed and its CRC checked,
its messages' times checked against the chunk's own bounds, and the message indexes written
after it checked against what it holds; the data section's CRC (when the writer kept one) and
the summary's CRC are checked too, and the messages counted per channel so that the summary's
statistics can be compared with them. A file damaged anywhere (its chunks, their indexes, its
summary) is not intact, even when its two ends still look right.
"""

from __future__ import annotations

import zlib
from collections import Counter
from dataclasses import dataclass, field
from typing import IO

import msgspec
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Chunk, DataEnd, Footer, Message, MessageIndex
from mcap.stream_reader import StreamReader, get_chunk_data_stream
from mcap.summary import Summary
from mcap.writer import MCAP0_MAGIC

from iw_zenoh.errors import IwError
from iw_zenoh.record.checksums import in_words
from iw_zenoh.record.reader import RecordingReader, decode_record

__all__ = ["Integrity", "scan", "statistics_disagree", "undecodable"]

FOOTER_BYTES = 1 + 8 + 8 + 8 + 4  # opcode, length, summary start, summary offset start, summary CRC
CRC_BYTES = 4


@dataclass
class Integrity:
    """What a scan of every record found.

    Attributes:
        problem: The first damage found ("" when none).
        messages: Messages read from the chunks.
        chunks: Chunks read.
        per_channel: Messages per channel id.
    """

    problem: str = ""
    messages: int = 0
    chunks: int = 0
    per_channel: dict[int, int] = field(default_factory=dict)


def _chunk_index(chunk: Chunk, out: Integrity) -> dict[int, list[tuple[int, int]]]:
    """(log time, offset) of each of the chunk's messages, per channel; checks CRC and times."""
    data: ReadDataStream
    data, length = get_chunk_data_stream(chunk, validate_crc=True)
    index: dict[int, list[tuple[int, int]]] = {}
    while data.count < length:
        offset = data.count
        opcode = data.read1()
        size = data.read8()
        if opcode != Opcode.MESSAGE:
            data.read(size)
            continue
        m = Message.read(data, size)
        if not chunk.message_start_time <= m.log_time <= chunk.message_end_time:
            raise ValueError(f"a message logged at {m.log_time} ns lies outside its chunk's time range")
        index.setdefault(m.channel_id, []).append((m.log_time, offset))
        out.per_channel[m.channel_id] = out.per_channel.get(m.channel_id, 0) + 1
        out.messages += 1
    if data.count != length:
        raise ValueError("a chunk's last record runs past its end")
    return index


def _summary_crc_ok(f: IO[bytes], footer: Footer, size: int) -> bool:
    if footer.summary_crc == 0:
        return True  # written without one
    start = footer.summary_start or size - len(MCAP0_MAGIC) - FOOTER_BYTES
    f.seek(start)
    covered = f.read(size - len(MCAP0_MAGIC) - CRC_BYTES - start)
    return zlib.crc32(covered) == footer.summary_crc


def scan(f: IO[bytes]) -> Integrity:
    """Reads every record of a recording in file order and checks it (see the module doc).

    Args:
        f: The recording, seekable.

    Returns:
        What was found; ``problem`` names the first damage, with where it was found.
    """
    out = Integrity()
    size = f.seek(0, 2)
    f.seek(0)
    pending: dict[int, list[tuple[int, int]]] = {}  # the last chunk's messages not yet met in an index
    where = "at the start"
    footer: Footer | None = None
    try:
        for rec in StreamReader(f, emit_chunks=True, validate_crcs=True).records:
            if isinstance(rec, Chunk):
                if pending:
                    raise ValueError(f"chunk {out.chunks}'s message index misses channels {sorted(pending)}")
                pending = _chunk_index(rec, out)
                out.chunks += 1
                where = f"in or after chunk {out.chunks} of the data section"
            elif isinstance(rec, MessageIndex):
                if sorted(rec.records) != sorted(pending.pop(rec.channel_id, [])):
                    raise ValueError(f"a message index of channel {rec.channel_id} disagrees with its chunk")
            elif isinstance(rec, DataEnd):
                if pending:
                    raise ValueError(f"the last chunk's message index misses channels {sorted(pending)}")
                where = "in the summary section"
            elif isinstance(rec, Footer):
                footer = rec
        if where != "in the summary section":
            raise ValueError("no data end record: the data section's end is damaged")
        if footer is None or not _summary_crc_ok(f, footer, size):
            raise ValueError("the summary section's CRC does not match: its indexes or statistics are damaged")
    except Exception as e:  # a damaged file raises anything from struct to zstd errors
        said = str(e).strip() if type(e) is ValueError else in_words(e).removeprefix("damaged: ")
        out.problem = f"damaged {where}: {said or 'the file is damaged'}"
    return out


def statistics_disagree(summary: Summary, found: Integrity) -> str:
    """How the summary's statistics disagree with the messages a scan read ("" when they agree)."""
    st = summary.statistics
    if st is None:
        return "the summary holds no statistics"
    if (st.message_count, st.chunk_count) != (found.messages, found.chunks):
        return (
            f"the summary counts {st.message_count} messages in {st.chunk_count} chunks; "
            f"the data section holds {found.messages} in {found.chunks}"
        )
    if {c: n for c, n in st.channel_message_counts.items() if n} != found.per_channel:
        return "the summary's messages per channel disagree with the data section"
    return ""


def undecodable(reader: RecordingReader) -> dict[str, int]:
    """Messages per topic that do not decode: into their key's type, or as JSON on other channels.

    Raises:
        RecordingError: When the recording cannot be read.
    """
    bad: Counter[str] = Counter()
    for r in reader.raw():
        if r.topic.startswith("/"):
            continue  # a derived channel (/foxglove/...): the recorder's own, in foxglove-sdk's protobuf
        try:
            if decode_record(r) is None:
                msgspec.json.decode(r.data)  # a derived or unknown channel: JSON all the same
        except (IwError, msgspec.DecodeError):
            bad[r.topic] += 1
    return dict(bad)
