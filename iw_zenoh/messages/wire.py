"""The wire's ground rules, shared by every message: the base class, the number types and
consistency checks, and the one ``encode`` and ``decode`` (see :mod:`iw_zenoh.messages`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sized
from types import ModuleType
from typing import Annotated, Any, ClassVar, TypeVar

import msgspec

from iw_zenoh.errors import DecodeError

T = TypeVar("T", bound="Message")

Finite = Annotated[float, msgspec.Meta(description="a finite number")]
INT64_MAX = 2**63 - 1  # every integer on the wire fits 64 bits (numpy arrays, MCAP times)
NonNeg = Annotated[int, msgspec.Meta(ge=0, le=INT64_MAX)]
RobotId = Annotated[int, msgspec.Meta(ge=0, le=INT64_MAX)]
Int64 = Annotated[int, msgspec.Meta(ge=-INT64_MAX - 1, le=INT64_MAX)]
SAY_MAX_BYTES = 100  # Ciber-Rato DCOSS: at most 100 bytes a message
COORD_LIMIT = 1e9  # a pose, power or distance beyond this (m, rad, deg) measures nothing real


# --- consistency checks, run by msgspec on every decode (a ValueError there is a refusal with its
# reason) and on every construction: kept to a few C-speed passes (a 1,000-robot state costs
# 20-30 us more to decode, ~170 us before)


def _lengths(n: int, of: str, arrays: Mapping[str, Sized]) -> None:
    """Refuses arrays that do not hold one value per robot (or per reading)."""
    for name, a in arrays.items():
        if len(a) != n:
            raise ValueError(f"{name} has {len(a)} values for {n} {of}")


def _unique(ids: list[int], name: str = "ids") -> set[int]:
    """Refuses a robot named twice; returns the set of ids."""
    seen = set(ids)
    if len(seen) != len(ids):
        once: set[int] = set()
        twice = next(i for i in ids if i in once or once.add(i))  # type: ignore[func-returns-value]
        raise ValueError(f"{name} name robot {twice} twice")
    return seen


def _magnitudes(arrays: Mapping[str, list[float]], limit: float = COORD_LIMIT) -> None:
    """Refuses an array holding a value beyond ``limit`` either way (its root sum of squares, one
    C pass, bounds every value; JSON carries no NaN, and one built here passes, to be refused
    by its receivers as before)."""
    for name, a in arrays.items():
        if math.hypot(*a) > limit:
            raise ValueError(f"{name} holds a value beyond +-{limit:g}")


def _bounded(values: dict[str, float], limit: float = COORD_LIMIT) -> None:
    """Refuses a number beyond ``limit`` either way."""
    for name, v in values.items():
        if abs(v) > limit:
            raise ValueError(f"{name} must be a finite number within +-{limit:g}, got {v!r}")


class Message(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Base of every wire message."""

    schema: ClassVar[str] = "iw.Message/1"
    tick: NonNeg = 0
    sim_time_ns: NonNeg = 0


Outgoing = tuple[str, Message]  # what logic hands its wiring to publish: a key and a message


class _Stamp(msgspec.Struct):
    sim_time_ns: int = 0
    tick: int = 0


_STAMP = msgspec.json.Decoder(_Stamp)


def stamp_of(data: bytes) -> tuple[int, int]:
    """``(tick, sim_time_ns)`` of any message, cheaply, each within 0..2**63-1; ``(0, 0)`` when
    it does not say."""
    try:
        s = _STAMP.decode(data)
    except (msgspec.DecodeError, msgspec.ValidationError):
        return 0, 0
    return min(max(0, s.tick), INT64_MAX), min(max(0, s.sim_time_ns), INT64_MAX)


_ENCODER = msgspec.json.Encoder()
_DECODERS: dict[type[Any], msgspec.json.Decoder[Any]] = {}


def encode(msg: msgspec.Struct) -> bytes:
    """Encodes any message (or derived channel, such as the Foxglove scene) as UTF-8 JSON.

    JSON has no NaN or infinity: msgspec writes them as ``null``, which a receiver refuses for a
    plain float field (fields that may be unknown are ``float | None``).
    """
    return _ENCODER.encode(msg)


def decode(data: bytes, kind: type[T]) -> T:
    """Decodes and validates a message of a known type.

    Args:
        data: The payload.
        kind: The message class expected on this key.

    Returns:
        The message.

    Raises:
        DecodeError: Naming the field and the reason; never a half-filled object.
    """
    dec = _DECODERS.get(kind)
    if dec is None:  # a type outside the package (every message's is made at import: prepare_decoders)
        dec = _DECODERS[kind] = msgspec.json.Decoder(kind)
    try:
        msg: T = dec.decode(data)
    except msgspec.ValidationError as e:
        upgraded = _upgraded(data, kind)  # written by an older version of the message?
        if upgraded is None:
            raise DecodeError(f"{kind.schema}: {e}") from None
        return upgraded
    except msgspec.DecodeError as e:
        raise DecodeError(f"{kind.schema}: not JSON: {e}") from None
    return msg


def prepare_decoders(*modules: ModuleType) -> int:
    """Makes the decoder of every ``msgspec.Struct`` defined in ``modules`` now, once (importing
    :mod:`iw_zenoh.messages` does it for every message); returns how many.

    msgspec works out how to decode a type on its first use and caches that on the type, unlocked:
    a thread that decodes the type meanwhile can find it half made and kill the process (SIGSEGV,
    no traceback; ``iwz view`` died so, its page pump and its Foxglove thread both decoding the
    world's first description). Made at import, before a process starts a thread, no message type
    is made twice or read half made, and ``msgspec.convert`` on them finds them made too.
    """
    made = 0
    for module in modules:
        for value in vars(module).values():
            if isinstance(value, type) and issubclass(value, msgspec.Struct) and value.__module__ == module.__name__:
                _DECODERS.setdefault(value, msgspec.json.Decoder(value))
                made += 1
    return made


def _upgraded(data: bytes, kind: type[T]) -> T | None:
    """A message its type's ``upgrade(doc)`` reads as an older version wrote it (renamed fields),
    or None: a type without one, or a message that is refused all the same. Only refused messages
    come here, so what every tick decodes costs nothing more."""
    upgrade = getattr(kind, "upgrade", None)
    if upgrade is None:
        return None
    try:
        doc = msgspec.json.decode(data)
        new = upgrade(doc) if isinstance(doc, dict) else doc
        if new == doc:
            return None
        return msgspec.convert(new, kind)
    except (msgspec.ValidationError, msgspec.DecodeError, RecursionError):
        return None


def json_schema(kind: type[msgspec.Struct]) -> dict[str, Any]:
    """The JSON Schema of a message class (what the recorder writes per channel)."""
    schema: dict[str, Any] = msgspec.json.schema(kind)
    return schema
