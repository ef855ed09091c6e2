"""``iwz doctor FILE`` and ``iwz recover FILE``: is a recording whole, and rebuild one cut off.

A file cut off by a crash has no summary and may end inside a chunk. ``recover`` reads records
from the start until the first one that is incomplete, and writes every message, schema and
channel of each chunk whose CRC matches, and the metadata, into a new, indexed file, reporting
what was lost: a chunk whose CRC fails is dropped whole (never decoded into altered messages).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Message,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)
from mcap.stream_reader import CRCValidationError, StreamReader
from mcap.writer import CompressionType, Writer

from iw_zenoh import __version__, keys
from iw_zenoh.errors import RecordingError
from iw_zenoh.record.checksums import in_words, verified_chunk
from iw_zenoh.record.integrity import FOOTER_BYTES, _summary_crc_ok, scan, statistics_disagree, undecodable
from iw_zenoh.record.parts import first_part, part_number, recording_parts, recovered_copy
from iw_zenoh.record.progress import Progress
from iw_zenoh.record.reader import RecordingReader, discard_cut_off, file_error
from iw_zenoh.record.recording import PROFILE

__all__ = ["Health", "check", "check_recording", "doctor_main", "recover", "recover_main"]

MAGIC = b"\x89MCAP0\r\n"


@dataclass
class Health:
    """What ``doctor`` found."""

    path: str
    whole: bool
    reason: str = ""
    messages: int = 0
    channels: int = 0
    chunks: int = 0
    start_ns: int = 0
    end_ns: int = 0
    metadata: list[str] = field(default_factory=list)
    counts_match: bool | None = None
    undecodable: int = 0  # payloads recorded as received that do not decode (malformed at their source)
    part: int = 0  # its number in a recording of several parts (0: a recording of one file)
    parts: int = 0  # how many parts that recording has
    recovered: str = ""  # a cut-off part's recovered copy, when it is whole (readers read it instead)
    described: bool | None = None  # whether it holds the world's description (world/info); None: not looked

    def lines(self) -> list[str]:
        """Human-readable report."""
        state = "whole" if self.whole else f"NOT whole: {self.reason}"
        which = f" (part {self.part} of {self.parts})" if self.part else ""
        out = [f"{self.path}{which}: {state}"]
        if self.recovered:
            return [*out, f"  its recovered copy {self.recovered} is whole: readers of the recording read that"]
        if self.whole:
            dur = (self.end_ns - self.start_ns) / 1e9
            out.append(
                f"  {self.messages} messages on {self.channels} channels in {self.chunks} chunks, "
                f"{dur:.1f} s of log time"
            )
            out.append(f"  metadata: {', '.join(self.metadata) or 'none'}")
            out.append(
                "  every message decodes into its key's type"
                if not self.undecodable
                else f"  {self.undecodable} messages do not decode into their key's type (recorded as received)"
            )
            if self.described is False:
                out.append(
                    "  it holds no world description (world/info): Foxglove draws no scene and iwz render "
                    "refuses it (the recorder now asks the world for it at the start of every part: record it again)"
                )
            if self.counts_match is not None:
                out.append(
                    f"  messages per key {'match' if self.counts_match else 'DO NOT match'} the recorder's own counts"
                )
        elif not Path(self.path).is_file():  # nothing there: iwz recover would only refuse it too
            out.append("  check the path: there is no file there to recover")
        elif "not an MCAP file" not in self.reason:
            out.append(f"  try: iwz recover {self.path}")
        return out


def _ends(f: IO[bytes], size: int) -> str:
    """What is wrong with the file's two ends ("" when both carry the MCAP magic)."""
    head = f.read(len(MAGIC))
    f.seek(max(0, size - len(MAGIC)))
    tail = f.read(len(MAGIC))
    if head != MAGIC:
        return "it does not start with the MCAP magic: not an MCAP file"
    if tail != MAGIC:
        return "it does not end with the MCAP magic: cut off (crash or still being written)"
    return ""


def check(path: str | Path) -> Health:
    """Checks a recording: magic at both ends, a readable summary, every record intact (chunk,
    message index and summary CRCs, statistics as the data section holds), every message
    decoded, and counts as the recorder saw them.
    """
    p = Path(path)
    try:
        with p.open("rb") as f:
            if reason := _ends(f, p.stat().st_size):
                return Health(str(p), False, reason)
            reader = RecordingReader(f, name=str(p))
            summary = reader.summary()
            if summary is None or summary.statistics is None:
                return Health(str(p), False, "it has no summary section: cut off before the recorder finished")
            found = scan(f)
            if reason := found.problem or statistics_disagree(summary, found):
                return Health(str(p), False, reason)
            meta = reader.metadata()
            bad = undecodable(reader)
    except OSError as e:
        return Health(str(p), False, f"unreadable: {e.strerror or e}")
    except RecordingError as e:
        return Health(str(p), False, f"unreadable: {e.reason}")
    st = summary.statistics
    h = Health(
        str(p),
        True,
        messages=st.message_count,
        channels=st.channel_count,
        chunks=st.chunk_count,
        start_ns=st.message_start_time,
        end_ns=st.message_end_time,
        metadata=sorted(meta),
        undecodable=sum(bad.values()),
    )
    h.described = any(
        n and (ch := summary.channels.get(cid)) is not None and keys.topic_kind(ch.topic) == "info"
        for cid, n in st.channel_message_counts.items()
    )
    counts = meta.get("iw.counts")
    if counts is not None:
        by_topic: dict[str, int] = {}
        for cid, n in st.channel_message_counts.items():
            ch = summary.channels.get(cid)
            if ch is not None:
                by_topic[ch.topic] = by_topic.get(ch.topic, 0) + n
        h.counts_match = all(by_topic.get(k, 0) == int(v) for k, v in counts.items())
    return h


@dataclass
class Recovery:
    """What ``recover`` saved and lost."""

    messages: int = 0
    channels: int = 0
    last_log_ns: int = 0
    good_bytes: int = 0
    total_bytes: int = 0
    stopped_by: str = ""
    per_topic: dict[str, int] = field(default_factory=dict)
    dropped_chunks: int = 0  # chunks whose CRC fails (or that have none): dropped whole
    orphans: int = 0  # messages of a channel whose record was in a dropped chunk
    unchecked: int = 0  # schema, channel or message records outside chunks: no CRC vouches for them, dropped
    metadata: str = "unchecked"  # "checked": the data section's CRC vouched for the metadata kept; or why not

    def lines(self, dst: Path, size: int) -> list[str]:
        """The report ``iwz recover`` prints."""
        lost = size - self.good_bytes if self.good_bytes else 0
        out = [
            f"iwz recover: {self.messages} messages on {self.channels} channels saved to {dst}",
            f"  last message logged at {self.last_log_ns} ns; {lost} bytes after the last complete record were lost",
            f"  reading stopped: {self.stopped_by or 'the file was complete'}",
        ]
        if self.dropped_chunks or self.orphans or self.unchecked:
            out.append(
                f"  dropped whole: {self.dropped_chunks} damaged chunks (their checksum fails), {self.orphans} "
                f"messages of channels declared in them, {self.unchecked} records outside chunks (no checksum)"
            )
        if self.metadata != "checked":
            out.append(f"  metadata kept but not vouched for: {self.metadata}")
        return out


class _Rebuild:
    """The new file being written: schemas and channels by their old ids, and what went in."""

    def __init__(self, dst: IO[bytes], out: Recovery) -> None:
        self.w = Writer(dst, compression=CompressionType.ZSTD, enable_data_crcs=True)
        self.w.start(profile=PROFILE, library=f"iw-zenoh {__version__} (recovered)")
        self.out = out
        self.schemas: dict[int, int] = {}
        self.channels: dict[int, tuple[int, str]] = {}

    def take(self, rec: object) -> None:
        """Writes a record a checksum vouched for (a schema, channel or message)."""
        if isinstance(rec, Schema) and rec.id not in self.schemas:
            self.schemas[rec.id] = self.w.register_schema(rec.name, rec.encoding, rec.data)
        elif isinstance(rec, Channel) and rec.id not in self.channels:
            cid = self.w.register_channel(
                rec.topic, rec.message_encoding, self.schemas.get(rec.schema_id, 0), rec.metadata
            )
            self.channels[rec.id] = (cid, rec.topic)
        elif isinstance(rec, Message):
            if rec.channel_id not in self.channels:
                self.out.orphans += 1
                return
            cid, topic = self.channels[rec.channel_id]
            self.w.add_message(cid, rec.log_time, rec.data, rec.publish_time, rec.sequence)
            self.out.messages += 1
            self.out.last_log_ns = max(self.out.last_log_ns, rec.log_time)
            self.out.per_topic[topic] = self.out.per_topic.get(topic, 0) + 1


def _summary_records(src: IO[bytes]) -> list[Schema | Channel]:
    """The schemas and channels of a summary section its CRC vouches for (none otherwise): the
    channels of a chunk dropped as damaged are still known, and their messages in other chunks kept."""
    try:
        size = src.seek(0, 2)
        src.seek(size - len(MAGIC) - FOOTER_BYTES)
        footer = next(StreamReader(src, skip_magic=True).records)
        if not isinstance(footer, Footer) or not footer.summary_start or not footer.summary_crc:
            return []
        if not _summary_crc_ok(src, footer, size):
            return []
        src.seek(footer.summary_start)
        found: list[Schema | Channel] = []
        for rec in StreamReader(src, skip_magic=True).records:
            if isinstance(rec, Schema | Channel):
                found.append(rec)
            elif not isinstance(rec, Statistics | ChunkIndex | MetadataIndex | SummaryOffset):
                break
        return found
    except Exception:  # a damaged or cut-off end: the file's own records are all there is
        return []
    finally:
        src.seek(0)


def recover(
    src: IO[bytes], dst: IO[bytes], total_bytes: int = 0, *, progress: Callable[[float], None] | None = None
) -> Recovery:
    """Copies every record a checksum vouches for of a (cut-off or damaged) recording into a new indexed file.

    A chunk is kept only when its CRC matches: one that fails it (or has none) is dropped whole,
    never decoded into altered messages; schema, channel and message records outside chunks have
    no CRC and are dropped; metadata is kept, vouched for when the data section's CRC matches.

    Args:
        src: The damaged recording, from its start, seekable.
        dst: Where the rebuilt file goes.
        total_bytes: The damaged file's size, for the report (and ``progress``).
        progress: Told now and then the fraction of ``total_bytes`` read.

    Returns:
        What was saved, and what dropped.
    """
    out = Recovery(total_bytes=total_bytes)
    new = _Rebuild(dst, out)
    for known in _summary_records(src):
        new.take(known)
    out.metadata = "the file ends before its data section's checksum"
    try:
        for rec in StreamReader(src, skip_magic=False, emit_chunks=True, validate_crcs=True).records:
            if isinstance(rec, Chunk):
                kept = verified_chunk(rec)
                out.dropped_chunks += kept is None
                for r in kept or ():
                    new.take(r)
            elif isinstance(rec, Schema | Channel | Message):
                out.unchecked += 1
            elif isinstance(rec, Metadata):
                new.w.add_metadata(rec.name, rec.metadata)
            elif isinstance(rec, DataEnd | Footer):  # the data section read to its end: nothing lost
                out.metadata = "checked" if isinstance(rec, DataEnd) and rec.data_section_crc else "written without one"
                out.good_bytes = total_bytes or out.good_bytes  # (its summary is written anew)
                break
            out.good_bytes = src.tell()
            if progress is not None and total_bytes:
                progress(out.good_bytes / total_bytes)
    except Exception as e:  # any truncation or corruption ends the readable part
        out.stopped_by = in_words(e)
        if isinstance(e, CRCValidationError):
            out.metadata = "the data section's checksum does not match"
    done = {"messages": str(out.messages), "stopped_by": out.stopped_by or "end of file"}
    done |= {"dropped_chunks": str(out.dropped_chunks), "orphans": str(out.orphans), "metadata": out.metadata}
    new.w.add_metadata("iw.recovered", done)
    new.w.finish()  # type: ignore[no-untyped-call]
    out.channels = len(new.channels)
    return out


def check_recording(path: str | Path) -> list[Health]:
    """Checks every part of the recording whose first part is ``path`` (just ``path`` when it is
    not a first part, or the recording has one); a cut-off part's recovered copy is checked too.
    """
    p = Path(path)
    paths = recording_parts(p) if first_part(p) == p else [p]
    if len(paths) == 1:
        return [check(p)]
    out = []
    for part in paths:
        h = check(part)
        h.part, h.parts = part_number(part), len(paths)
        copy = recovered_copy(part)
        if not h.whole and copy.exists() and check(copy).whole:
            h.recovered = str(copy)
        out.append(h)
    return out


def _recording_lines(found: list[Health]) -> list[str]:
    """A recording of several parts: how many are whole, which to recover, time not recorded between them."""
    if len(found) < 2:
        return []
    cut = [h for h in found if not h.whole and not h.recovered]
    out = [
        f"{found[0].path}: a recording of {len(found)} parts, "
        + ("every part readable" if not cut else f"{len(found) - len(cut)} readable, {len(cut)} not whole")
    ]
    out += [f"  part {h.part} ({h.path}) is not whole: iwz recover {h.path}" for h in cut]
    for a, b in zip(found, found[1:], strict=False):
        if a.whole and b.whole and b.start_ns > a.end_ns > 0:
            out.append(
                f"  {(b.start_ns - a.end_ns) / 1e9:.3f} s of log time not recorded between parts {a.part} and {b.part}"
            )
    return out


def doctor_main(argv: Sequence[str] | None = None) -> int:
    """``iwz doctor FILE...``: exit 0 when every file (every part of a recording) is whole, 1 otherwise.

    A cut-off part whose recovered copy is whole counts as whole (readers read the copy).
    """
    p = argparse.ArgumentParser(
        prog="iwz doctor", description="Say whether recordings are whole (magic, summary, indexes, counts)."
    )
    p.add_argument("files", nargs="+", help="MCAP files")
    p.add_argument("--json", action="store_true", help="one JSON object per file")
    args = p.parse_args(argv)
    ok = True
    for f in args.files:
        found = check_recording(f)
        for h in found:
            ok &= h.whole or bool(h.recovered)
            print(json.dumps(h.__dict__) if args.json else "\n".join(h.lines()))
        if not args.json and (more := _recording_lines(found)):
            print("\n".join(more))
    return 0 if ok else 1


def recover_main(argv: Sequence[str] | None = None) -> int:
    """``iwz recover FILE [-o OUT]``."""
    p = argparse.ArgumentParser(
        prog="iwz recover",
        description="Rebuild a readable, indexed recording from one cut off by a crash, and say what was lost.",
    )
    p.add_argument("file", help="the damaged MCAP file")
    p.add_argument("-o", "--output", help="where to write (default FILE with .recovered.mcap)")
    args = p.parse_args(argv)
    src = Path(args.file)
    dst = Path(args.output) if args.output else recovered_copy(src)
    if dst.resolve() == src.resolve():
        print("iwz recover: the output must differ from the input")
        return 2
    try:
        size = src.stat().st_size
        with src.open("rb") as fi:
            if fi.read(len(MAGIC)) != MAGIC:
                print(f"iwz recover: {src}: not an MCAP file (it does not start with the MCAP magic); nothing written")
                return 1
            fi.seek(0)
            said = Progress("iwz recover")
            with dst.open("wb") as fo:
                r = recover(fi, fo, size, progress=lambda f: said.update(f, f"{f * size / 1e6:.0f} MB"))
            said.done()
    except OSError as e:
        discard_cut_off(dst, e)
        print(f"iwz recover: {file_error(src, e, output=dst)}")
        return 2
    if r.messages == 0 and r.stopped_by:
        dst.unlink(missing_ok=True)
        print(f"iwz recover: {src}: nothing could be saved, no complete message in it ({r.stopped_by})")
        return 1
    print("\n".join(r.lines(dst, size)))
    return 0
