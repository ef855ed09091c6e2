"""The exception tree of iw-zenoh.

Every error the project raises on purpose is one of these::

    IwError
     +-- ConfigError        a config, scenario or robot spec that is refused
     |    +-- MapError      a map, grid or parameters file that is refused
     |    +-- SpecError     a robot registration field that is refused
     +-- ProtocolError      bytes from the outside that are refused
     |    +-- DecodeError   a wire message that does not decode
     +-- RecordingError     a recording that cannot be read (names the file and the reason)
     +-- LogError           a chair's CSV log that is refused (names the file, line and the fix)

Each carries enough to say *what*, *where* and *how to fix*: the field, file, line or key
involved, and the reason.
"""

from __future__ import annotations

__all__ = [
    "ConfigError",
    "DecodeError",
    "IwError",
    "LogError",
    "MapError",
    "ProtocolError",
    "RecordingError",
    "SpecError",
]


class IwError(Exception):
    """The root of every error this project raises on purpose."""


class ConfigError(IwError):
    """A configuration value is refused.

    Args:
        field: The dotted name of the offending field (``"robots[2].max_speed"``).
        reason: Why it is refused, phrased so the user knows how to fix it.
    """

    def __init__(self, field: str, reason: str) -> None:
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")


class SpecError(ConfigError):
    """A robot registration field is refused (out of range, wrong type, duplicate)."""


class MapError(ConfigError):
    """A map, grid or parameters file is refused.

    Args:
        source: The file name (or ``"<bytes>"``).
        line: The 1-based line of the offending element, or ``None``.
        element: The element name (``"Wall"``, ``"Corner"``...).
        reason: Why it is refused.
    """

    def __init__(self, source: str, line: int | None, element: str, reason: str) -> None:
        self.source = source
        self.line = line
        self.element = element
        where = f"{source}:{line}" if line is not None else source
        super().__init__(f"{where}: <{element}>", reason)
        self.args = (f"{where}: <{element}>: {reason}",)

    def __str__(self) -> str:
        return str(self.args[0])


class ProtocolError(IwError):
    """Bytes from outside (a datagram, a serial frame, a wire message) are refused."""


class DecodeError(ProtocolError):
    """A wire message does not decode into its declared type."""


class RecordingError(IwError):
    """A recording cannot be read: not MCAP, cut off, or damaged.

    Args:
        source: The file name (or what the stream is called).
        reason: What is wrong with it.
    """

    def __init__(self, source: str, reason: str) -> None:
        self.source = source
        self.reason = reason
        super().__init__(f"{source}: {reason}")


class LogError(IwError):
    """A chair's CSV log (``iwz calibrate``'s input) is refused.

    Args:
        source: The file name.
        line: The 1-based line at fault, or ``None`` for the file as a whole.
        reason: What is wrong there and how to fix it.
    """

    def __init__(self, source: str, line: int | None, reason: str) -> None:
        self.source = source
        self.line = line
        self.reason = reason
        where = f"{source} line {line}" if line is not None else source
        super().__init__(f"{where}: {reason}")
