"""The legacy datagrams' framing and XML, shared by every parser and builder of the Ciber-Rato
protocol: size limits and the NUL terminator, the one hardened lxml parser, attribute readers
that refuse what the legacy server would misread, and the writer's formatting.

Framing: every datagram the server sends ends in exactly one NUL (after a newline); what clients
send may or may not carry one, and anything after the first NUL is ignored. Malformed input raises
:class:`~iw_zenoh.errors.ProtocolError` with the reason, never a half-parsed value.
"""

from __future__ import annotations

import math
import threading

from lxml import etree

from iw_zenoh.errors import ProtocolError

__all__ = ["digits", "finish", "float_attr", "fmt_g", "frame", "onoff", "parse_xml", "root_is"]

_PARSERS = threading.local()


def _parser() -> etree.XMLParser:
    """The hardened parser, one per thread (building one costs more than parsing an Actions)."""
    p: etree.XMLParser | None = getattr(_PARSERS, "parser", None)
    if p is None:
        p = _PARSERS.parser = etree.XMLParser(
            resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False, remove_comments=True
        )
    return p


def frame(datagram: bytes, limit: int) -> bytes:
    """The XML text of a datagram: refused past ``limit`` bytes, cut at the first NUL.

    Raises:
        ProtocolError: When it is longer than the legacy server would read, or empty.
    """
    if len(datagram) > limit + 1:  # one terminating NUL past the limit is how the C clients send
        raise ProtocolError(f"datagram of {len(datagram)} bytes is over the {limit}-byte limit")
    text = datagram.split(b"\x00", 1)[0]
    if not text.strip():
        raise ProtocolError("empty datagram")
    return text


_AFTER_NAME = (b"", b" ", b"\t", b"\r", b"\n", b"/", b">")


def root_is(text: bytes, roots: tuple[bytes, ...]) -> bool:
    """Whether the text can start with one of ``roots`` (a few byte comparisons, no parsing: most
    of a flood is refused here); a declaration or a DOCTYPE is left to the parser."""
    t = text.lstrip()
    if t.startswith((b"<?", b"<!")):
        return True
    return any(t.startswith(r) and t[len(r) : len(r) + 1] in _AFTER_NAME for r in roots)


def parse_xml(text: bytes) -> etree._Element:
    """The root element of a datagram's text, read by the hardened parser.

    Raises:
        ProtocolError: Not well-formed XML, or a DOCTYPE.
    """
    try:
        root = etree.fromstring(text, _parser())
    except etree.XMLSyntaxError as e:
        raise ProtocolError(f"not well-formed XML: {e.msg}") from None
    tree = root.getroottree()
    if tree.docinfo.internalDTD is not None or tree.docinfo.doctype:
        raise ProtocolError("DOCTYPE declarations are refused")
    return root


def float_attr(el: etree._Element, *names: str) -> float | None:
    """The first of ``names`` (spellings of one attribute) that ``el`` has, as a number; None
    when it has none of them.

    Raises:
        ProtocolError: A value that is not a finite number.
    """
    for n in names:
        raw = el.get(n)
        if raw is None:
            continue
        try:
            v = float(raw)
        except ValueError:
            raise ProtocolError(f"<{el.tag}> {n}={raw!r} is not a number") from None
        if not math.isfinite(v):
            raise ProtocolError(f"<{el.tag}> {n}={raw!r} is not a finite number")
        return v
    return None


def digits(raw: str | None, what: str) -> int | None:
    """A whole number written in ASCII digits (spaces around allowed); None when absent or not
    digits at all (the caller's legacy rule applies).

    Raises:
        ProtocolError: For digits that are not ASCII: ``str.isdigit()`` holds for "²" or "٣",
            which ``int()`` refuses or reads as another number than the legacy server would.
    """
    if raw is None:
        return None
    text = raw.strip()
    if not text.isdigit():
        return None
    if not text.isascii():
        raise ProtocolError(f"{what}={raw!r} is not written in ASCII digits")
    return int(text)


def fmt_g(v: float) -> str:
    """A number as the legacy server prints it (``%g``)."""
    return f"{v:g}"


def onoff(v: bool) -> str:
    """``On`` or ``Off``."""
    return "On" if v else "Off"


def finish(root: etree._Element) -> bytes:
    """An element as a datagram the server sends: tab indents, a newline and the NUL."""
    etree.indent(root, space="\t")
    return bytes(etree.tostring(root, encoding="utf-8")) + b"\n\x00"
