"""A recording's parts: how they are named, how they are found, and how one part is read.

A recorder restarted on a recording (``iwz record --continue``, as the launcher does after a
crash) does not overwrite it: it writes the next part beside it. The first part keeps the name
given, the next ones insert ``.partN`` before the suffix::

    run.mcap  run.part2.mcap  run.part3.mcap ...

Each part is a complete MCAP file of its own, with the recording's metadata and ``iw.part``
(its number, the recording's id, the part before it). :func:`recording_parts` finds a
recording's parts from any one of them; :class:`Part` reads one, whole or cut off: a part cut
off by a crash is read up to its first incomplete record, and says what it lost.
"""

from __future__ import annotations

import io
import re
import uuid
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from pathlib import Path
from typing import IO, TypeVar

from mcap.reader import McapReader, make_reader
from mcap.records import Channel, Chunk, Message, Metadata
from mcap.stream_reader import StreamReader
from mcap.summary import Summary
from mcap.writer import MCAP0_MAGIC as MAGIC

from iw_zenoh.errors import RecordingError
from iw_zenoh.record.checksums import checksums_fail, in_words

__all__ = [
    "PART_META",
    "Part",
    "first_part",
    "head_metadata",
    "next_part",
    "open_parts",
    "part_number",
    "part_path",
    "reason",
    "recording_parts",
    "recovered_copy",
]

# the least a whole file holds: its magic, the header record (opcode, length, two empty strings),
# the footer record (opcode, length, two offsets, a CRC) and the closing magic
WHOLE_MIN_BYTES = len(MAGIC) + (1 + 8 + 4 + 4) + (1 + 8 + 8 + 8 + 4) + len(MAGIC)
PART_META = "iw.part"  # metadata: part (number), recording (id), previous (the part before, by name)

_PART = re.compile(r"^(?P<stem>.+)\.part(?P<n>[0-9]+)$")

T = TypeVar("T")


def part_path(first: Path, n: int) -> Path:
    """Part ``n`` (from 1) of the recording whose first part is ``first``: ``run.partN.mcap``."""
    return first if n == 1 else first.with_name(f"{first.stem}.part{n}{first.suffix}")


def part_number(path: Path) -> int:
    """Which part of its recording ``path`` is, by its name (1 for the first)."""
    m = _PART.match(path.stem)
    return int(m["n"]) if m and int(m["n"]) >= 2 else 1


def first_part(path: Path) -> Path:
    """The first part of the recording ``path`` belongs to (``run.part3.mcap`` -> ``run.mcap``)."""
    m = _PART.match(path.stem)
    return path.with_name(f"{m['stem']}{path.suffix}") if m and int(m["n"]) >= 2 else path


def recording_parts(path: str | Path) -> list[Path]:
    """Every existing part of the recording ``path`` belongs to, in order (``[path]`` when alone)."""
    first = first_part(Path(path))
    if not first.parent.is_dir():
        return [Path(path)]
    later = {}
    for p in first.parent.iterdir():
        if p.suffix == first.suffix and p.name.startswith(first.stem + ".part") and first_part(p) == first:
            later[part_number(p)] = p
    found = ([first] if first.exists() else []) + [later[n] for n in sorted(later) if n >= 2]
    return found or [Path(path)]


def recovered_copy(path: Path) -> Path:
    """Where ``iwz recover`` writes its rebuilt copy of ``path`` by default."""
    return path.with_suffix(".recovered.mcap")


def reason(e: BaseException) -> str:
    """An exception as a reason a user can read, in words (never the exception's name)."""
    if isinstance(e, OSError) and e.strerror:
        return e.strerror
    return in_words(e)


def head_metadata(stream: IO[bytes]) -> dict[str, dict[str, str]]:
    """The metadata a recording's writer put before its first chunk (whole or cut off: fast).

    Returns:
        Metadata by name; empty when the stream is not MCAP or breaks before any.
    """
    stream.seek(0)
    out: dict[str, dict[str, str]] = {}
    try:
        for rec in StreamReader(stream, emit_chunks=True).records:
            if isinstance(rec, Chunk):
                break
            if isinstance(rec, Metadata):
                out[rec.name] = dict(rec.metadata)
    except Exception:  # noqa: S110 - not MCAP, or cut off inside its head: what was read is all there is
        pass
    stream.seek(0)
    return out


def next_part(first: Path, run: str | None) -> tuple[Path, dict[str, str], dict[str, str]]:
    """Where a recorder starting on the recording ``first`` writes, and what it says about it.

    Args:
        first: The recording's file (its first part).
        run: ``None`` to start the recording afresh (its later parts are removed, as the first
            is overwritten); else continue it, when it exists and, unless ``run`` is empty, its
            id is ``run`` (an empty ``run`` continues whatever recording is there).

    Returns:
        The file to write, its ``iw.part`` metadata, and the first part's ``iw.user`` metadata
        when continuing (else empty).
    """
    parts = [p for p in recording_parts(first) if p.exists()]
    head: dict[str, dict[str, str]] = {}
    if parts:
        with parts[0].open("rb") as f:
            head = head_metadata(f)
    rec_id = head.get(PART_META, {}).get("recording", "")
    if run is not None and parts and (not run or run == rec_id):
        n = part_number(parts[-1]) + 1
        meta = {"part": str(n), "recording": rec_id or run or uuid.uuid4().hex, "previous": parts[-1].name}
        return part_path(first, n), meta, head.get("iw.user", {})
    for stale in parts[1:]:
        stale.unlink(missing_ok=True)
    return first, {"part": "1", "recording": run or uuid.uuid4().hex, "previous": ""}, {}


def open_parts(path: Path, files: ExitStack, *, validate_crcs: bool = True) -> tuple[list[Part], list[str]]:
    """Opens every part of the recording ``path`` belongs to (see :func:`iw_zenoh.record.reader.open_recording`).

    A cut-off part is read from its recovered copy when there is one of it (same recording, same
    part); else, in a recording of several parts, as far as it goes. A whole part whose data or
    summary section fails its checksum is refused (:func:`~iw_zenoh.record.checksums.checksums_fail`).

    Returns:
        The parts, and a note for each part read from its recovered copy.

    Raises:
        RecordingError: When a file cannot be opened, is not MCAP or is damaged (or, alone, is cut off).
    """
    paths = recording_parts(path) if path.exists() else [path]  # a part not there is no other part's name
    parts = []
    notes = []
    for p in paths:
        part = Part(_open(p, files), str(p), validate_crcs=validate_crcs, cut_off_ok=len(paths) > 1)
        copy = recovered_copy(p)
        if part.cut_off and copy.exists() and _same_part(part.stream, _open(copy, files)):
            part = Part(_open(copy, files), str(copy), validate_crcs=validate_crcs)
            notes.append(f"{p} is cut off (a crash): read from its recovered copy {copy}")
        part.refuse_damage()
        parts.append(part)
    return parts, notes


def _open(path: Path, files: ExitStack) -> IO[bytes]:
    try:
        return files.enter_context(path.open("rb"))
    except OSError as e:
        raise RecordingError(str(path), reason(e)) from e


def _same_part(part: IO[bytes], copy: IO[bytes]) -> bool:
    """Whether ``copy`` was recovered from this part (and not from an older recording of that name)."""
    ours = head_metadata(part).get(PART_META, {})
    theirs = head_metadata(copy).get(PART_META, {})
    return ours.get("recording") == theirs.get("recording") and ours.get("part") == theirs.get("part")


class Part:
    """One part of a recording, read whole or, when cut off and ``cut_off_ok``, as far as it goes.

    Args:
        stream: The part, a seekable binary stream from its start (or not seekable: read in order).
        name: What to call it in errors and notes.
        validate_crcs: Check each chunk's CRC as it is read.
        cut_off_ok: Read a part that does not end as MCAP does up to its first incomplete
            record (else refuse it).

    Raises:
        RecordingError: When it is not MCAP (or is cut off, without ``cut_off_ok``).
    """

    def __init__(self, stream: IO[bytes], name: str, *, validate_crcs: bool = False, cut_off_ok: bool = False) -> None:
        self.name = name
        self.stream = stream
        self.size = 0
        self.lost = ""  # for a cut-off part, once read: where reading stopped and why
        self.read_messages = 0
        if stream.seekable():
            if (size := stream.seek(0, io.SEEK_END)) < len(MAGIC):
                raise RecordingError(self.name, f"only {size} bytes: empty, or not an MCAP file")
            self.size = size
            stream.seek(0)
        self._reader: McapReader = self.guard(lambda: make_reader(stream, validate_crcs=validate_crcs))
        self.cut_off = self.guard(self._ends_cut)
        if self.cut_off and not cut_off_ok:
            raise RecordingError(
                self.name, f"cut off after {self.size} bytes (a crash, or still being written): iwz recover rebuilds it"
            )

    def refuse_damage(self) -> None:
        """Raises ``RecordingError`` when the part is whole but its checksums fail."""
        if self.cut_off or not self.stream.seekable():
            return
        if why := self.guard(lambda: checksums_fail(self.stream)):
            raise RecordingError(
                self.name,
                f"{why}: refused; iwz doctor {self.name} says where, iwz recover {self.name} keeps what is intact",
            )

    def _ends_cut(self) -> bool:
        if not self.stream.seekable():
            return False
        if self.size < WHOLE_MIN_BYTES:  # a magic, and nothing after it that ends a file
            return True
        self.stream.seek(self.size - len(MAGIC))
        cut = self.stream.read(len(MAGIC)) != MAGIC
        self.stream.seek(0)
        return cut

    def guard(self, call: Callable[[], T]) -> T:
        """``call()``, whatever mcap raises on a bad file turned into a ``RecordingError``."""
        try:
            return call()
        except RecordingError:
            raise
        except Exception as e:  # mcap raises many kinds (struct, zstd, ValueError...) on a bad file
            raise RecordingError(self.name, reason(e)) from e

    def summary(self) -> Summary | None:
        """The part's summary (``None`` when cut off or written without one)."""
        return None if self.cut_off else self.guard(self._reader.get_summary)

    def metadata(self) -> dict[str, dict[str, str]]:
        """Every metadata record, by name (the last of a name wins)."""
        self.stream.seek(0)
        if not self.cut_off:
            return self.guard(lambda: {m.name: dict(m.metadata) for m in self._reader.iter_metadata()})
        return {m.name: dict(m.metadata) for m in self._stream() if isinstance(m, Metadata)}

    def topics(self) -> set[str]:
        """The topics of its channels."""
        summary = self.summary()
        if summary is not None:
            return {c.topic for c in summary.channels.values()}
        return {c.topic for c in self._stream() if isinstance(c, Channel)}

    def messages(self, log_start: int | None) -> Iterator[tuple[Channel, Message]]:
        """Its messages from log time ``log_start`` on (in log-time order; a cut-off part in file order)."""
        self.stream.seek(0)
        if not self.cut_off:
            for _, ch, msg in self._reader.iter_messages(starting_at=log_start):
                yield ch, msg
            return
        channels: dict[int, Channel] = {}
        self.read_messages = 0
        for rec in self._stream():
            if isinstance(rec, Channel):
                channels[rec.id] = rec
            elif isinstance(rec, Message) and rec.channel_id in channels:
                self.read_messages += 1
                if log_start is None or rec.log_time >= log_start:
                    yield channels[rec.channel_id], rec

    def _stream(self) -> Iterator[object]:
        """The records of a cut-off part up to its first incomplete one (noted in ``lost``)."""
        self.stream.seek(0)
        try:
            yield from StreamReader(self.stream, emit_chunks=False, validate_crcs=True).records
        except Exception as e:  # the cut, or damage before it: what follows is lost
            at = self.stream.tell() if self.stream.seekable() else 0
            self.lost = f"read up to byte {at} of {self.size}, the rest is lost ({reason(e)})"
