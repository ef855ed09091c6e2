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

import io
import logging
from collections.abc import Callable, Collection, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, TypeVar

import zenoh
from mcap.exceptions import InvalidMagic
from mcap.reader import McapReader, make_reader
from mcap.records import Channel
from mcap.summary import Summary
from mcap.writer import MCAP0_MAGIC as MAGIC

from iw_zenoh import keys
from iw_zenoh.errors import IwError, RecordingError
from iw_zenoh.messages import TOPIC_TYPES, Message, decode

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
]

logger = logging.getLogger(__name__)

T = TypeVar("T")


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


def file_error(source: str | Path, e: Exception) -> str:
    """An error about a file as ``FILE: reason`` (whatever raised it, named once, never an errno).

    Args:
        source: The file the command was working on.
        e: What went wrong (an ``OSError`` names its own file when it has one).
    """
    if isinstance(e, RecordingError):
        return str(e)
    if isinstance(e, OSError) and e.filename is not None:
        return f"{e.filename}: {_reason(e)}"
    return f"{source}: {_reason(e) if isinstance(e, OSError) else e}"


def _reason(e: BaseException) -> str:
    """An exception as a reason a user can read (some of mcap's say nothing on their own)."""
    if isinstance(e, InvalidMagic):
        return "not an MCAP file (it does not start with the MCAP magic)"
    if isinstance(e, OSError) and e.strerror:
        return e.strerror
    text = str(e).strip()
    return f"{type(e).__name__}: {text}" if text else f"{type(e).__name__} (the file is damaged or not MCAP)"


class RecordingReader:
    """Reads one recording.

    Args:
        stream: The recording, a seekable binary stream from its start.
        name: What to call it in errors (a file name).
        validate_crcs: Check each chunk's CRC as it is read (doctor does).
        on_bad: Called with each payload that does not decode (default: logged at debug level).

    Raises:
        RecordingError: When it is not an MCAP stream.
    """

    def __init__(
        self,
        stream: IO[bytes],
        *,
        name: str | None = None,
        validate_crcs: bool = False,
        on_bad: Callable[[BadMessage], None] | None = None,
    ) -> None:
        self.name = name or str(getattr(stream, "name", "<stream>"))
        self._stream = stream
        self._on_bad = on_bad
        self.bad: dict[str, int] = {}  # undecodable payloads per topic
        if stream.seekable():
            if (size := stream.seek(0, io.SEEK_END)) < len(MAGIC):
                raise RecordingError(self.name, f"only {size} bytes: empty, or not an MCAP file")
            stream.seek(0)
        self._reader: McapReader = self._guard(lambda: make_reader(stream, validate_crcs=validate_crcs))
        self._guard(self._check_end)

    def _check_end(self) -> None:
        """A file that does not end as MCAP does is cut off: say so before mcap trips on it."""
        if not self._stream.seekable():
            return
        size = self._stream.seek(0, io.SEEK_END)
        if size >= len(MAGIC):
            self._stream.seek(size - len(MAGIC))
        if size < len(MAGIC) or self._stream.read(len(MAGIC)) != MAGIC:
            raise RecordingError(
                self.name, f"cut off after {size} bytes (a crash, or still being written): iwz recover rebuilds it"
            )
        self._stream.seek(0)

    def _guard(self, call: Callable[[], T]) -> T:
        try:
            return call()
        except RecordingError:
            raise
        except Exception as e:  # mcap raises many kinds (struct, zstd, ValueError...) on a bad file
            raise RecordingError(self.name, _reason(e)) from e

    def summary(self) -> Summary | None:
        """The file's summary section (``None`` for a file written without one).

        Raises:
            RecordingError: When the file is cut off or its summary is damaged.
        """
        return self._guard(self._reader.get_summary)

    def metadata(self) -> dict[str, dict[str, str]]:
        """Every metadata record, by name (the last of a name wins)."""
        self._stream.seek(0)
        return self._guard(lambda: {m.name: dict(m.metadata) for m in self._reader.iter_metadata()})

    def raw(
        self,
        kinds: Collection[str] | None = None,
        *,
        topics: Callable[[str], bool] | None = None,
        window: Window = EVERYTHING,
    ) -> Iterator[RawRecord]:
        """Every message as recorded, in log-time order.

        Args:
            kinds: Only keys of these kinds (``None``: every channel, derived ones included).
            topics: Only topics it accepts (a :class:`KeyFilter`, or any predicate).
            window: Only messages inside this time window.

        Raises:
            RecordingError: When the file is unreadable from some point on.
        """
        wanted: dict[int, tuple[bool, str | None]] = {}  # channel id -> (read it, its kind)

        def accept(ch: Channel) -> tuple[bool, str | None]:
            kind = keys.topic_kind(ch.topic)
            return (kinds is None or kind in kinds) and (topics is None or topics(ch.topic)), kind

        self._stream.seek(0)
        try:
            for _, ch, msg in self._reader.iter_messages(starting_at=window.log_start):
                got = wanted.get(ch.id)
                if got is None:
                    got = wanted[ch.id] = accept(ch)
                read, kind = got
                if not read:
                    continue
                if not window.holds(msg.publish_time):
                    continue
                yield RawRecord(ch.topic, kind, msg.log_time, msg.publish_time, msg.data)
        except Exception as e:  # mcap raises many kinds (struct, zstd, CRC, ValueError...) on a bad file
            raise RecordingError(self.name, _reason(e)) from e

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
    validate_crcs: bool = False,
    on_bad: Callable[[BadMessage], None] | None = None,
) -> Iterator[RecordingReader]:
    """Opens a recording for reading.

    Args:
        source: A file name, or a seekable binary stream (left open).
        validate_crcs: Check each chunk's CRC as it is read.
        on_bad: Called with each payload that does not decode.

    Yields:
        Its reader.

    Raises:
        RecordingError: When the file cannot be opened or is not MCAP, naming it and the reason.
    """
    if isinstance(source, str | Path):
        path = Path(source)
        try:
            f = path.open("rb")
        except OSError as e:
            raise RecordingError(str(path), _reason(e)) from e
        with f:
            yield RecordingReader(f, name=str(path), validate_crcs=validate_crcs, on_bad=on_bad)
    else:
        yield RecordingReader(source, validate_crcs=validate_crcs, on_bad=on_bad)
