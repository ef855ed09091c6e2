"""Serial lines: a pseudo-terminal the emulator creates, or any device or pyserial URL.

Both read with a timeout and write without blocking: a line nobody reads fills up and what
does not fit is dropped (a board does not wait for a computer that is not listening).
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import select
import tty
from typing import Protocol

import serial

__all__ = ["Line", "LinkLost", "PtyLine", "SerialLine"]

logger = logging.getLogger(__name__)


class LinkLost(OSError):
    """The device is gone (cable pulled, USB adapter removed, the pty closed)."""


class Line(Protocol):
    """A byte pipe with a read timeout."""

    def read(self, timeout_s: float) -> bytes:
        """Bytes available within ``timeout_s`` (b"" for none). Raises LinkLost."""

    def write(self, data: bytes) -> None:
        """Writes what fits now. Raises LinkLost."""

    def close(self) -> None:
        """Closes the line."""


class PtyLine:
    """The board side of a pseudo-terminal: ``path`` is what a bridge opens.

    Args:
        link: Also make this path a symbolic link to the pty (stays the same across
            unplug / replug, when the pty's own name changes); "" for none.
    """

    def __init__(self, link: str = "") -> None:
        self.link = link
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # no echo, no line discipline: bytes as they are
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self.slave)
        if link:
            tmp = f"{link}.tmp{os.getpid()}"
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            os.symlink(self.path, tmp)
            os.replace(tmp, link)  # atomic: a bridge never sees the link half made

    def read(self, timeout_s: float) -> bytes:
        """Bytes the computer wrote."""
        ready, _, _ = select.select([self.master], [], [], max(0.0, timeout_s))
        if not ready:
            return b""
        try:
            return os.read(self.master, 4096)
        except BlockingIOError:
            return b""
        except OSError as e:
            if e.errno == errno.EIO:  # nobody has the other end open (yet)
                return b""
            raise LinkLost(str(e)) from e

    def write(self, data: bytes) -> None:
        """Writes what the pty takes; the rest is dropped."""
        with contextlib.suppress(BlockingIOError, InterruptedError):
            os.write(self.master, data)

    def close(self) -> None:
        """Pulls the cable: the link goes, then the pty."""
        if self.link:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.link)
        for fd in (self.slave, self.master):
            with contextlib.suppress(OSError):
                os.close(fd)


class SerialLine:
    """A device path or any pyserial URL (``/dev/ttyUSB0``, ``loop://``, ``socket://h:p``).

    Args:
        port: The device or URL.
        baud: Bits a second.

    Raises:
        LinkLost: It cannot be opened.
    """

    def __init__(self, port: str, baud: int = 115200) -> None:
        try:
            self.port = serial.serial_for_url(port, baudrate=baud, timeout=0, write_timeout=0, exclusive=True)
        except (serial.SerialException, OSError, ValueError) as e:
            raise LinkLost(f"{port}: {e}") from e
        with contextlib.suppress(serial.SerialException, OSError):
            self.port.reset_input_buffer()  # what a previous session left is stale

    def read(self, timeout_s: float) -> bytes:
        """Bytes from the device within ``timeout_s``."""
        try:
            fd = self.port.fileno()
        except (AttributeError, serial.SerialException, OSError):
            fd = None
        try:
            if fd is not None:
                ready, _, _ = select.select([fd], [], [], max(0.0, timeout_s))
                if not ready:
                    return b""
                data = bytes(self.port.read(4096))
                if not data:  # readable yet empty: the device went away
                    raise LinkLost(f"{self.port.port}: device gone")
                return data
            self.port.timeout = max(0.0, timeout_s)
            return bytes(self.port.read(max(1, self.port.in_waiting)))
        except (serial.SerialException, OSError) as e:
            raise LinkLost(f"{self.port.port}: {e}") from e

    def write(self, data: bytes) -> None:
        """Writes what the device takes now."""
        try:
            self.port.write(data)
        except serial.SerialTimeoutException:
            logger.debug("write dropped: the line is full")
        except (serial.SerialException, OSError) as e:
            raise LinkLost(f"{self.port.port}: {e}") from e

    def close(self) -> None:
        """Closes the device."""
        with contextlib.suppress(serial.SerialException, OSError):
            self.port.close()
