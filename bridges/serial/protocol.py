"""The chair-board link protocol (RS-232): versioned, COBS-framed, sequenced, CRC-checked frames.

Pure: bytes in, messages out, and back. The layout, byte by byte, is in ``docs/serial.md``.

A frame before framing is::

    version u8 | type u8 | seq u16 | length u8 | payload (length bytes) | crc u16

little-endian, except the CRC (CRC-16/CCITT-FALSE over everything before it, big-endian). It is
then COBS-encoded (no zero byte inside) and ends with one ``0x00`` delimiter, so a receiver that
starts mid-stream or loses bytes finds the next frame at the next zero.

:class:`FrameDecoder` takes the byte stream in pieces of any size and returns the good frames;
every corrupt, truncated, oversized, unknown or out-of-order frame is counted and dropped, and no
input whatsoever makes it raise.
"""

from __future__ import annotations

import binascii
import struct
from dataclasses import dataclass, field

from cobs import cobs

__all__ = [
    "MAX_POWER_UNITS",
    "NO_RANGE",
    "VERSION",
    "Clear",
    "DecoderStats",
    "EStop",
    "Frame",
    "FrameDecoder",
    "Heartbeat",
    "Message",
    "Motors",
    "Status",
    "decode_frame",
    "encode_frame",
    "power_from_units",
    "power_to_units",
]

VERSION = 1  # bump on any layout change; a receiver drops frames of another version
DELIMITER = b"\x00"
HEADER = struct.Struct("<BBHB")  # version, type, seq, payload length
CRC = struct.Struct(">H")
MAX_PAYLOAD = 255  # the length is one byte
MAX_ENCODED = HEADER.size + MAX_PAYLOAD + CRC.size + 3  # COBS adds one byte per 254 and one up front
POWER_SCALE = 10_000  # motor power travels as 1e-4 units: +-0.15 is +-1500
MAX_POWER_UNITS = 1500
NO_RANGE = 0xFFFF  # a range of "nothing within reach"
SEQ_MOD = 1 << 16
SEQ_WINDOW = SEQ_MOD // 2  # a seq up to this far ahead of the last one is newer (RFC 1982 style)

T_MOTORS, T_ESTOP, T_CLEAR, T_HEARTBEAT = 0x01, 0x02, 0x03, 0x04
T_STATUS = 0x81

FLAG_ESTOP = 0x01  # e-stop latched
FLAG_WATCHDOG = 0x02  # the board's watchdog holds the motors at zero
FLAG_ESTOP_BOARD = 0x04  # the latched e-stop came from the chair's side (button, bumper)

_MOTORS = struct.Struct("<hh")
_STATUS = struct.Struct("<HiihhHBBBB")  # ack, enc l, enc r, wheel l, wheel r, battery mV, bumpers, flags, fault, n


@dataclass(frozen=True)
class Motors:
    """Computer to chair: motor powers, in 1e-4 power units (+-1500 is +-0.15, MaxSpeed)."""

    left: int
    right: int


@dataclass(frozen=True)
class EStop:
    """Computer to chair: stop now and stay stopped until a :class:`Clear`."""


@dataclass(frozen=True)
class Clear:
    """Computer to chair: an operator clears a latched e-stop."""


@dataclass(frozen=True)
class Heartbeat:
    """Computer to chair: the link is alive (feeds the board's watchdog, changes no command)."""


@dataclass(frozen=True)
class Status:
    """Chair to computer: everything the board measures, once a board cycle.

    Attributes:
        ack: Sequence number of the last Motors frame applied.
        encoders: Left and right encoder counts since power-up (wrapping int32).
        wheels: The powers the motors are driven at now, 1e-4 units (what the chair does).
        battery_mv: Battery voltage, millivolts.
        bumpers: Bumper contacts, bit i = bumper i pressed.
        flags: FLAG_ESTOP, FLAG_WATCHDOG, FLAG_ESTOP_BOARD.
        fault: Board fault code (0: none).
        ranges_mm: Proximity sensors 0..n-1 (sonars and infrareds), millimetres, NO_RANGE for none.
    """

    ack: int
    encoders: tuple[int, int]
    wheels: tuple[int, int]
    battery_mv: int
    bumpers: int = 0
    flags: int = 0
    fault: int = 0
    ranges_mm: tuple[int, ...] = ()


Message = Motors | EStop | Clear | Heartbeat | Status
_EMPTY: dict[int, Message] = {T_ESTOP: EStop(), T_CLEAR: Clear(), T_HEARTBEAT: Heartbeat()}


@dataclass(frozen=True)
class Frame:
    """A decoded frame: its sequence number and message."""

    seq: int
    msg: Message


def power_to_units(power: float) -> int:
    """Motor power ([-0.15, 0.15]) to wire units, clamped."""
    return max(-MAX_POWER_UNITS, min(MAX_POWER_UNITS, round(power * POWER_SCALE)))


def power_from_units(units: int) -> float:
    """Wire units to motor power."""
    return units / POWER_SCALE


def _payload(msg: Message) -> tuple[int, bytes]:
    if isinstance(msg, Motors):
        return T_MOTORS, _MOTORS.pack(msg.left, msg.right)
    if isinstance(msg, EStop):
        return T_ESTOP, b""
    if isinstance(msg, Clear):
        return T_CLEAR, b""
    if isinstance(msg, Heartbeat):
        return T_HEARTBEAT, b""
    head = _STATUS.pack(
        msg.ack,
        msg.encoders[0],
        msg.encoders[1],
        msg.wheels[0],
        msg.wheels[1],
        msg.battery_mv,
        msg.bumpers,
        msg.flags,
        msg.fault,
        len(msg.ranges_mm),
    )
    return T_STATUS, head + struct.pack(f"<{len(msg.ranges_mm)}H", *msg.ranges_mm)


def encode_frame(msg: Message, seq: int) -> bytes:
    """One message as a framed, delimited frame ready for the wire.

    Args:
        msg: The message.
        seq: Its sequence number (taken modulo 65536).

    Returns:
        COBS-encoded bytes ending with the 0x00 delimiter.

    Raises:
        struct.error: A field out of its wire range (e.g. more than 120 ranges).
    """
    kind, payload = _payload(msg)
    body = HEADER.pack(VERSION, kind, seq % SEQ_MOD, len(payload)) + payload
    body += CRC.pack(binascii.crc_hqx(body, 0xFFFF))
    return bytes(cobs.encode(body)) + DELIMITER


def _message(kind: int, payload: bytes) -> Message | None:
    if kind == T_MOTORS and len(payload) == _MOTORS.size:
        left, right = _MOTORS.unpack(payload)
        return Motors(left, right)
    if not payload and kind in _EMPTY:
        return _EMPTY[kind]
    if kind == T_STATUS and len(payload) >= _STATUS.size:
        ack, el, er, wl, wr, mv, bumpers, flags, fault, n = _STATUS.unpack_from(payload)
        if len(payload) != _STATUS.size + 2 * n:
            return None
        ranges = struct.unpack_from(f"<{n}H", payload, _STATUS.size)
        return Status(ack, (el, er), (wl, wr), mv, bumpers, flags, fault, tuple(ranges))
    return None


def decode_frame(encoded: bytes) -> Frame | str:
    """One frame (COBS-encoded, without its delimiter) to a Frame, or the reason it is refused."""
    try:
        body = bytes(cobs.decode(encoded))
    except cobs.DecodeError:
        return "corrupt"
    if len(body) < HEADER.size + CRC.size:
        return "truncated"
    if binascii.crc_hqx(body[: -CRC.size], 0xFFFF) != CRC.unpack_from(body, len(body) - CRC.size)[0]:
        return "corrupt"
    version, kind, seq, length = HEADER.unpack_from(body)
    if version != VERSION:
        return "version"
    if len(body) != HEADER.size + length + CRC.size:
        return "truncated"
    msg = _message(kind, body[HEADER.size : HEADER.size + length])
    if msg is None:
        return "unknown"
    return Frame(seq, msg)


@dataclass
class DecoderStats:
    """What a decoder accepted and dropped, by reason."""

    frames: int = 0
    dropped: dict[str, int] = field(default_factory=dict)

    @property
    def dropped_total(self) -> int:
        """Every frame dropped, whatever the reason."""
        return sum(self.dropped.values())


class FrameDecoder:
    """Splits a byte stream into frames; keeps the good, in-order ones; never raises.

    A frame whose sequence number is not newer than the last accepted one (a duplicate, or one
    that arrives late) is dropped as ``out-of-order``. :meth:`resync` forgets the last number,
    so the next good frame is accepted whatever its number (the peer restarted).
    """

    def __init__(self) -> None:
        self.stats = DecoderStats()
        self._buf = bytearray()
        self._last: int | None = None
        self._skipping = False  # an oversized frame: drop bytes up to the next delimiter

    def resync(self) -> None:
        """Accepts the next good frame whatever its sequence number."""
        self._last = None

    def _drop(self, reason: str) -> None:
        self.stats.dropped[reason] = self.stats.dropped.get(reason, 0) + 1

    def feed(self, data: bytes) -> list[Frame]:
        """Takes bytes from the line; returns the frames completed by them, in order."""
        out: list[Frame] = []
        for chunk_i, chunk in enumerate(bytes(data).split(DELIMITER)):
            if chunk_i > 0:  # a delimiter ended the frame in the buffer
                self._end(out)
            if self._skipping:
                continue
            self._buf += chunk
            if len(self._buf) > MAX_ENCODED:
                self._drop("oversized")
                self._buf.clear()
                self._skipping = True
        return out

    def _end(self, out: list[Frame]) -> None:
        if self._skipping:
            self._skipping = False
            return
        encoded = bytes(self._buf)
        self._buf.clear()
        if not encoded:
            return  # back-to-back delimiters: idle line, not an error
        got = decode_frame(encoded)
        if isinstance(got, str):
            self._drop(got)
            return
        if self._last is not None and not 0 < (got.seq - self._last) % SEQ_MOD < SEQ_WINDOW:
            self._drop("out-of-order")
            return
        self._last = got.seq
        self.stats.frames += 1
        out.append(got)
