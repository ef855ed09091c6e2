"""Reading recordings: the one loop over a recording's messages that every tool shares.

Replay, incidents, render, resim and doctor open a recording here and ask for its messages by
kind of key (``state``, ``event``...), by key expression and by time window. :meth:`RecordingReader.records`
decodes each into its message type (:data:`iw_zenoh.messages.TOPIC_TYPES`); a payload that does
not decode is reported (counted, and handed to ``on_bad``) and skipped, never fatal, since the
recorder keeps what it received byte for byte, malformed or not. :meth:`RecordingReader.raw`
yields the payloads as recorded, every channel included (Foxglove scene channels too).

Whatever makes the file unreadable (not MCAP, cut off, a corrupt chunk) raises
:class:`~iw_zenoh.errors.RecordingError` naming the file and the reason.
"""

from __future__ import annotations

import errno
import logging
import sys
from collections.abc import Callable, Collection, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import zenoh
from mcap.summary import Summary

from iw_zenoh import keys
from iw_zenoh.errors import IwError, RecordingError
from iw_zenoh.messages import TOPIC_TYPES, Message, decode
from iw_zenoh.record.parts import Part, open_parts, reason

__all__ = [
    "EVERYTHING",
    "BadMessage",
    "KeyFilter",
    "RawRecord",
    "Record",
    "RecordingReader",
    "Window",
    "decode_record",
    "file_error",
    "open_recording",
    "print_notes",
]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class _Stamped:
    """Where and when a recorded message was received.

    Attributes:
        topic: The key (or, for derived channels, the topic) it was recorded on.
        kind: What the key carries (:func:`iw_zenoh.keys.topic_kind`); ``None`` off the key space.
        log_time: When the recorder received it, wall clock ns.
        publish_time: Its simulation time, ns.
    """

    topic: str
    kind: str | None
    log_time: int
    publish_time: int


@dataclass(frozen=True, slots=True)
class RawRecord(_Stamped):
    """One recorded message as it was received: ``data`` is the payload, byte for byte."""

    data: bytes


@dataclass(frozen=True, slots=True)
class Record(_Stamped):
    """One recorded message, its ``message`` decoded into the type its kind of key carries."""

    message: Message


@dataclass(frozen=True, slots=True)
class BadMessage:
    """A recorded payload that does not decode into its key's message type.

    Attributes:
        topic: The key it was recorded on.
        log_time: When the recorder received it, wall clock ns.
        reason: Why it does not decode.
    """

    topic: str
    log_time: int
    reason: str


@dataclass(frozen=True)
class Window:
    """A time window over a recording.

    Attributes:
        log_start: From this log time on, ns (found through the file's index, not by reading).
        sim_start: From this simulation time on, ns.
        sim_end: Up to this simulation time (included), ns.
    """

    log_start: int | None = None
    sim_start: int | None = None
    sim_end: int | None = None

    def holds(self, sim_ns: int) -> bool:
        """Whether simulation time ``sim_ns`` is inside."""
        return (self.sim_start is None or sim_ns >= self.sim_start) and (self.sim_end is None or sim_ns <= self.sim_end)


EVERYTHING = Window()


@dataclass(frozen=True)
class KeyFilter:
    """Which keys to read: any of ``include`` (all when empty) and none of ``exclude``.

    Patterns are Zenoh key expressions (``iw/*/world/**``). A topic that is not a Zenoh key (a
    derived ``/foxglove/...`` channel) matches no pattern: it passes only an empty ``include``.
    """

    include: tuple[str, ...] = ()
    exclude: tuple[str, ...] = ()
    _inc: tuple[zenoh.KeyExpr, ...] = field(init=False, repr=False, compare=False)
    _exc: tuple[zenoh.KeyExpr, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        """Parses the patterns (a malformed one raises ``IwError``)."""
        object.__setattr__(self, "_inc", tuple(_key_expr(p, pattern=True) for p in self.include))
        object.__setattr__(self, "_exc", tuple(_key_expr(p, pattern=True) for p in self.exclude))

    def __call__(self, topic: str) -> bool:
        """Whether ``topic`` passes."""
        if not self._inc and not self._exc:
            return True
        try:
            k = _key_expr(topic)
        except IwError:
            return not self._inc
        if self._inc and not any(p.intersects(k) for p in self._inc):
            return False
        return not any(p.intersects(k) for p in self._exc)


def _key_expr(text: str, *, pattern: bool = False) -> zenoh.KeyExpr:
    try:
        return zenoh.KeyExpr(text)
    except zenoh.ZError as e:
        what = "key expression" if pattern else "key"
        raise IwError(f"{text!r} is not a Zenoh {what}: {str(e).split(' at ')[0]}") from e


WRITE_ERRNOS = frozenset((errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS))  # only a write fails so


def discard_cut_off(output: str | Path, e: BaseException) -> None:
    """Removes ``output`` when ``e`` is an error only a write has (the disk full): a copy, picture
    or page cut off there is of no use, and holds the space it took."""
    if isinstance(e, OSError) and e.errno in WRITE_ERRNOS:
        Path(output).unlink(missing_ok=True)


def file_error(source: str | Path, e: Exception, output: str | Path | None = None) -> str:
    """An error about a file as ``FILE: reason`` (whatever raised it, named once, never an errno).

    Args:
        source: The file the command was working on.
        e: What went wrong (an ``OSError`` names its own file when it has one).
        output: The file the command writes, if any: named for an error only a write can have
            (the disk full), which Python raises without a file name.
    """
    if isinstance(e, RecordingError):
        return str(e)
    if isinstance(e, OSError) and e.filename is not None:
        return f"{e.filename}: {reason(e)}"
    if isinstance(e, OSError) and output is not None and e.errno in WRITE_ERRNOS:
        return f"{output}: {reason(e)}"
    return f"{source}: {reason(e) if isinstance(e, OSError) else e}"


class RecordingReader:
    """Reads one recording: one stream, or every part of a recording as one.

    Args:
        stream: The recording, a seekable binary stream from its start (``None`` with ``parts``).
        name: What to call it in errors (a file name).
        validate_crcs: Check each chunk's CRC as it is read (doctor does).
        on_bad: Called with each payload that does not decode (default: logged at debug level).
        parts: The recording's parts, in order, instead of ``stream`` (see :func:`open_recording`).

    Attributes:
        notes: What a reader of the whole should know: a part cut off (and what of it was read),
            a part read from its recovered copy, the log time between two parts not recorded.

    Raises:
        RecordingError: When it is not an MCAP stream (or, a single stream, is cut off).
    """

    def __init__(
        self,
        stream: IO[bytes] | None = None,
        *,
        name: str | None = None,
        validate_crcs: bool = False,
        on_bad: Callable[[BadMessage], None] | None = None,
        parts: Sequence[Part] = (),
    ) -> None:
        if stream is not None:
            parts = [Part(stream, name or str(getattr(stream, "name", "<stream>")), validate_crcs=validate_crcs)]
        if not parts:
            raise ValueError("a recording needs a stream or its parts")
        self.parts = list(parts)
        self.name = name or self.parts[0].name
        self._on_bad = on_bad
        self.bad: dict[str, int] = {}  # undecodable payloads per topic
        self.notes: list[str] = [
            f"{p.name} is cut off (a crash): read as far as it goes; iwz recover {p.name} rebuilds it"
            for p in self.parts
            if p.cut_off
        ]
        self._total = sum(p.size for p in self.parts)
        self._done = 0  # bytes of the parts read through

    def summary(self) -> Summary | None:
        """The first part's summary section (``None`` for a part cut off or written without one).

        Raises:
            RecordingError: When its summary is damaged.
        """
        return self.parts[0].summary()

    def metadata(self) -> dict[str, dict[str, str]]:
        """Every metadata record, by name; a name in several parts merges their maps (later parts win)."""
        out: dict[str, dict[str, str]] = {}
        for p in self.parts:
            for k, v in p.metadata().items():
                out.setdefault(k, {}).update(v)
        return out

    def topics(self) -> set[str]:
        """Every channel's topic, over all parts."""
        return set().union(*(p.topics() for p in self.parts))

    def progress(self) -> float:
        """How far reading has gone through the recording's bytes, 0 to 1 (roughly: chunks are read in time order)."""
        if not self._total:
            return 0.0
        return min(1.0, sum(p.size for p in self.parts[: self._done]) / self._total + self._at() / self._total)

    def _at(self) -> int:
        if self._done >= len(self.parts):
            return 0
        s = self.parts[self._done].stream
        try:
            return s.tell() if s.seekable() else 0
        except (OSError, ValueError):
            return 0

    def raw(
        self,
        kinds: Collection[str] | None = None,
        *,
        topics: Callable[[str], bool] | None = None,
        window: Window = EVERYTHING,
    ) -> Iterator[RawRecord]:
        """Every message as recorded, in log-time order (part after part).

        Args:
            kinds: Only keys of these kinds (``None``: every channel, derived ones included).
            topics: Only topics it accepts (a :class:`KeyFilter`, or any predicate).
            window: Only messages inside this time window.

        Raises:
            RecordingError: When a whole part is unreadable from some point on.
        """
        wanted: dict[str, tuple[bool, str | None]] = {}  # topic -> (read it, its kind)

        def accept(topic: str) -> tuple[bool, str | None]:
            kind = keys.topic_kind(topic)
            return (kinds is None or kind in kinds) and (topics is None or topics(topic)), kind

        last: tuple[str, int] | None = None  # the previous part, and its last log time
        for i, part in enumerate(self.parts):
            self._done = i
            first_log: int | None = None
            end = 0
            try:
                for ch, msg in part.messages(window.log_start):
                    first_log = msg.log_time if first_log is None else first_log
                    end = max(end, msg.log_time)
                    read, kind = wanted.get(ch.topic) or wanted.setdefault(ch.topic, accept(ch.topic))
                    if read and window.holds(msg.publish_time):
                        yield RawRecord(ch.topic, kind, msg.log_time, msg.publish_time, msg.data)
            except RecordingError:
                raise
            except Exception as e:  # mcap raises many kinds (struct, zstd, CRC, ValueError...) on a bad file
                raise RecordingError(part.name, reason(e)) from e
            self._note_part(part, last, first_log)
            if first_log is not None:
                last = (part.name, end)
        self._done = len(self.parts)

    def _note_part(self, part: Part, last: tuple[str, int] | None, first_log: int | None) -> None:
        """Notes what a part lost at its end, and the log time between it and the one before."""
        notes = []
        if part.lost:
            notes.append(f"{part.name}: {part.read_messages} messages read, {part.lost}")
        if last is not None and first_log is not None and first_log > last[1]:
            gap_s = (first_log - last[1]) / 1e9
            notes.append(f"{gap_s:.3f} s of log time not recorded between {last[0]} and {part.name}")
        self.notes.extend(n for n in notes if n not in self.notes)

    def records(
        self,
        kinds: Collection[str] | None = None,
        *,
        topics: Callable[[str], bool] | None = None,
        window: Window = EVERYTHING,
    ) -> Iterator[Record]:
        """Every message of the key space's kinds, decoded, in log-time order.

        Takes the filters of :meth:`raw` (``kinds`` ``None`` meaning every kind that has a message
        type). A payload that does not decode is counted in :attr:`bad`, reported to ``on_bad``
        and skipped.

        Raises:
            RecordingError: When the file is unreadable from some point on.
        """
        known = TOPIC_TYPES.keys() if kinds is None else [k for k in kinds if k in TOPIC_TYPES]
        for r in self.raw(known, topics=topics, window=window):
            try:
                rec = decode_record(r)
            except IwError as e:
                self._bad(BadMessage(r.topic, r.log_time, str(e)))
                continue
            if rec is not None:
                yield rec

    def _bad(self, bad: BadMessage) -> None:
        self.bad[bad.topic] = self.bad.get(bad.topic, 0) + 1
        if self._on_bad is not None:
            self._on_bad(bad)
        else:
            logger.debug("%s: a message on %s does not decode: %s", self.name, bad.topic, bad.reason)


def decode_record(r: RawRecord) -> Record | None:
    """A recorded message decoded into the type its kind of key carries.

    Returns:
        The record, or ``None`` for a channel whose kind has no message type (a derived one).

    Raises:
        DecodeError: When the payload does not decode into that type.
    """
    cls = TOPIC_TYPES.get(r.kind) if r.kind is not None else None
    if cls is None:
        return None
    return Record(r.topic, r.kind, r.log_time, r.publish_time, decode(r.data, cls))


@contextmanager
def open_recording(
    source: str | Path | IO[bytes],
    *,
    validate_crcs: bool = True,
    on_bad: Callable[[BadMessage], None] | None = None,
) -> Iterator[RecordingReader]:
    """Opens a recording for reading: every part of it, as one, from any of its parts.

    A recording of several parts (``run.mcap``, ``run.part2.mcap``...) is read part after part;
    a part cut off by a crash is read as far as it goes, or from its recovered copy
    (``run.part2.recovered.mcap``) when ``iwz recover`` made one, and the reader's ``notes`` say
    so. A recording of one part that is cut off is refused (``iwz recover`` rebuilds it), and so is
    a whole part whose checksums fail (a damaged file: its data could be altered).

    Args:
        source: A file name, or a seekable binary stream (left open; one part).
        validate_crcs: Check each chunk's CRC as it is read (a stream source only: a file's
            checksums are always checked).
        on_bad: Called with each payload that does not decode.

    Yields:
        Its reader.

    Raises:
        RecordingError: When a file cannot be opened or is not MCAP, naming it and the reason.
    """
    if not isinstance(source, str | Path):
        yield RecordingReader(source, validate_crcs=validate_crcs, on_bad=on_bad)
        return
    with ExitStack() as files:
        parts, notes = open_parts(Path(source), files)
        reader = RecordingReader(name=str(parts[0].name), on_bad=on_bad, parts=parts)
        reader.notes[:0] = notes
        yield reader


def print_notes(prog: str, reader: RecordingReader) -> None:
    """Prints a reader's notes (parts cut off, time not recorded) to stderr, as ``PROG: note: ...``."""
    for note in reader.notes:
        try:
            print(f"{prog}: note: {note}", file=sys.stderr, flush=True)
        except (OSError, ValueError):  # stderr closed: nobody to tell
            return
