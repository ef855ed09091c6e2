"""What a recording's checksums vouch for, and a damaged file's errors said in words.

An iw-zenoh recording carries three kinds of CRC-32: one per chunk (of its records,
uncompressed), one of the whole data section (in its data end record) and one of the summary
section (in the footer). :func:`checksums_fail` checks the last two, which between them cover
every byte of a whole file but the footer's own: readers (``open_recording``) refuse a file
whose sums fail before they use anything in it. :func:`verified_chunk` is how ``iwz recover``
reads a chunk: only when its CRC vouches for it (a chunk written without one, CRC 0, is not
vouched for: every iw-zenoh writer keeps one, so a 0 there is damage too).
"""

from __future__ import annotations

import io
import struct
import zlib
from typing import IO

from mcap.exceptions import EndOfFile, InvalidMagic, RecordLengthLimitExceeded
from mcap.opcode import Opcode
from mcap.records import Chunk, McapRecord
from mcap.stream_reader import CRCValidationError, breakup_chunk
from mcap.writer import MCAP0_MAGIC as MAGIC

__all__ = ["checksums_fail", "in_words", "verified_chunk"]

FOOTER_BYTES = 1 + 8 + 8 + 8 + 4  # opcode, length, summary start, summary offset start, summary CRC
DATA_END_BYTES = 1 + 8 + 4  # opcode, length, data section CRC
BLOCK = 1 << 20
COMPRESSIONS = ("zstd", "lz4", "")


def in_words(e: BaseException) -> str:
    """What a damaged file's exception means, said in words (never the exception's name)."""
    if isinstance(e, InvalidMagic):
        return "not an MCAP file (it does not start with the MCAP magic)"
    if isinstance(e, CRCValidationError):
        return "damaged: a checksum does not match what it covers"
    if isinstance(e, UnicodeDecodeError):
        return "damaged: a record's text is not UTF-8"
    if isinstance(e, EndOfFile | struct.error):
        return "damaged or cut off: a record runs past the end of what holds it"
    if isinstance(e, RecordLengthLimitExceeded | MemoryError | OverflowError):
        return "damaged: a record's length is impossibly large"
    if type(e).__module__.startswith(("zstandard", "lz4")) or "compress" in str(e).lower():
        return "damaged: a chunk does not decompress"
    text = str(e).strip().splitlines()[0] if str(e).strip() else ""
    return f"damaged or not MCAP ({text})" if text else "damaged or not MCAP"


def _u64(data: bytes, at: int) -> int:
    return int.from_bytes(data[at : at + 8], "little")


def _crc(f: IO[bytes], start: int, end: int) -> int:
    f.seek(start)
    crc = 0
    while start < end:
        block = f.read(min(BLOCK, end - start))
        if not block:
            break
        crc = zlib.crc32(block, crc)
        start += len(block)
    return crc


def checksums_fail(f: IO[bytes]) -> str:
    """Why a whole file's data section or summary section fails its CRC ("" when both match, or
    when its writer kept none). Reads the file once, in order, and leaves it at its start.

    Args:
        f: The recording, seekable, ending with the MCAP magic.
    """
    size = f.seek(0, io.SEEK_END)
    try:
        at_footer = size - len(MAGIC) - FOOTER_BYTES
        f.seek(at_footer)
        footer = f.read(FOOTER_BYTES)
        if len(footer) != FOOTER_BYTES or footer[0] != Opcode.FOOTER:
            return "damaged: its footer is not where a whole file has it"
        summary_start, summary_crc = _u64(footer, 9), int.from_bytes(footer[25:29], "little")
        if not 0 <= summary_start <= at_footer:
            return "damaged: its footer points outside the file"
        data_end = (summary_start or at_footer) - DATA_END_BYTES
        if summary_crc and _crc(f, summary_start or at_footer, size - len(MAGIC) - 4) != summary_crc:
            return "damaged: the summary section's checksum does not match (its indexes or statistics)"
        if data_end < len(MAGIC):
            return "damaged: no room for its data end record"
        f.seek(data_end)
        rec = f.read(DATA_END_BYTES)
        if rec[0] != Opcode.DATA_END or _u64(rec, 1) != 4:
            return "damaged: its data end record is not where the footer says the summary starts"
        data_crc = int.from_bytes(rec[9:13], "little")
        if data_crc and _crc(f, 0, data_end) != data_crc:
            return "damaged: the data section's checksum does not match (a chunk, index or metadata record)"
        return ""
    finally:
        f.seek(0)


def verified_chunk(chunk: Chunk) -> list[McapRecord] | None:
    """The records of a chunk its CRC vouches for; ``None`` when it has no CRC, fails it, or
    does not decompress or parse (a damaged chunk: dropped whole, never read in part)."""
    if not chunk.uncompressed_crc or chunk.compression not in COMPRESSIONS:
        return None
    try:
        return breakup_chunk(chunk, validate_crc=True)
    except Exception:  # CRC, zstd, struct, UTF-8...: all mean the same here, the chunk is damaged
        return None
