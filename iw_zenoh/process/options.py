"""A role's typed options: one ``msgspec.Struct`` per role that ``iwz run`` configures, filled by
the role's flags or handed whole as ``--options JSON``.

Its flags are declared as a table (:data:`Flag`, :func:`add_option_flags`) and fill it
(:func:`options_from_args`); ``--options JSON`` hands it whole (:func:`options_json`; long ones
as ``--options @FILE``, :func:`options_argument`), decoded
and validated by msgspec, so ``iwz run`` passes typed configuration instead of strings the child
parses again.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TypeVar

import msgspec

from iw_zenoh.errors import IwError

__all__ = [
    "Flag",
    "add_option_flags",
    "add_options_argument",
    "declared_flags",
    "option",
    "options_from_args",
    "options_argument",
    "options_json",
]

S = TypeVar("S", bound=msgspec.Struct)

INLINE_MAX = 32 * 1024  # longer options go to a child in a file (--options @FILE), not its command line
OPTION_DEST = "option:"  # the dest of a flag that fills an options field: never clashes with --mode, --name


def option(field_name: str) -> str:
    """The ``dest`` of a flag that fills the options field ``field_name`` (see :func:`options_from_args`)."""
    return OPTION_DEST + field_name


# one flag of a role: its names ("-o --output"), the options field it fills, how argparse reads
# it (type, action, metavar...), and its help ("{default}" is replaced by the field's default)
Flag = tuple[str, str, dict[str, Any], str]


def add_option_flags(parser: argparse.ArgumentParser, kind: type[msgspec.Struct], flags: Sequence[Flag]) -> None:
    """Adds a role's flags, each filling a field of ``kind`` (see :data:`Flag`), and ``--options``.

    A flag not given leaves its field to ``--options`` or the default (``argparse.SUPPRESS``);
    :func:`options_from_args` then reads them into a ``kind``.
    """
    defaults = kind()
    for names, name, how, text in flags:
        text = text.format(default=getattr(defaults, name))
        if how.get("action", "store") in ("store", "append") and "choices" not in how:
            how = {"metavar": names.split()[-1].lstrip("-").upper(), **how}  # not OPTION:FIELD
        parser.add_argument(*names.split(), dest=option(name), default=argparse.SUPPRESS, help=text, **how)
    add_options_argument(parser, kind)


def declared_flags(kind: type[msgspec.Struct]) -> tuple[Flag, ...]:
    """A role's flags generated from its options Struct: one for each field whose type carries a
    ``msgspec.Meta(description=...)``, so that a new option is one line in the Struct.

    The flag is ``--`` and the field's name with ``-`` for ``_``, unless ``Meta.extra["flag"]``
    spells it; argparse reads it as the field's type says (a number as ``int``/``float``, an enum
    as its values' ``choices``, a ``bool`` as a switch, ``extra["const"]`` as a switch setting
    that value); the rest of ``extra`` (``metavar``, ``type``, ``action``) goes to argparse as
    is. The help is the description (``{default}`` is the field's default, see
    :func:`add_option_flags`) and the range the type declares; the range itself is checked when
    the options are built (:func:`options_from_args`), naming the field.
    """
    flags: list[Flag] = []
    for field in msgspec.inspect.type_info(kind).fields:  # type: ignore[attr-defined]
        declared = field.type
        if not isinstance(declared, msgspec.inspect.Metadata):
            continue
        text = (declared.extra_json_schema or {}).get("description")
        if not text:
            continue
        extra = dict(declared.extra or {})
        names = extra.pop("flag", "--" + field.name.replace("_", "-"))
        how = {**_reading(declared.type, extra), **extra}
        flags.append((names, field.name, how, text + _range(declared.type)))
    return tuple(flags)


def _reading(declared: Any, extra: dict[str, Any]) -> dict[str, Any]:
    """How argparse reads a value of the inspected type ``declared``."""
    inspect = msgspec.inspect
    if "const" in extra:
        return {"action": "store_const"}
    if isinstance(declared, inspect.UnionType):  # X | None: a flag gives an X
        given = [t for t in declared.types if not isinstance(t, inspect.NoneType)]
        declared = given[0] if len(given) == 1 else declared
    if isinstance(declared, inspect.BoolType):
        return {"action": "store_true"}
    if isinstance(declared, inspect.IntType):
        return {"type": int}
    if isinstance(declared, inspect.FloatType):
        return {"type": float}
    if isinstance(declared, inspect.EnumType):
        return {"choices": [e.value for e in declared.cls]}
    return {}


def _range(declared: Any) -> str:
    """The range a number's inspected type declares, as the flag's help says it ("" if none)."""
    bound = {name: getattr(declared, name, None) for name in ("ge", "gt", "le", "lt")}
    if bound["ge"] is not None and bound["le"] is not None and bound["gt"] is bound["lt"] is None:
        return f" ({bound['ge']:.15g} to {bound['le']:.15g})"
    words = {"ge": "at least", "gt": "more than", "le": "at most", "lt": "less than"}
    said = [f"{words[name]} {value:.15g}" for name, value in bound.items() if value is not None]
    return f" ({', '.join(said)})" if said else ""


def options_json(options: msgspec.Struct) -> str:
    """``options`` as the ``--options JSON`` a role's command line takes (what ``iwz run`` passes)."""
    return msgspec.json.encode(options).decode()


def options_argument(options: msgspec.Struct, spill: Path) -> str:
    """The value of ``--options`` that hands ``options`` to a child: its JSON, or, past
    :data:`INLINE_MAX` characters (a world of thousands of obstacles: a command line's argument
    is limited to 128 KiB), ``@FILE`` with the JSON written to ``spill``."""
    text = options_json(options)
    if len(text) <= INLINE_MAX:
        return text
    spill.write_text(text, encoding="utf-8")
    return "@" + str(spill)


def _options_text(value: str) -> str:
    """``--options``'s JSON: the value, or the file ``@FILE`` names."""
    if not value.startswith("@"):
        return value
    try:
        return Path(value[1:]).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise IwError(f"--options {value}: cannot read it ({getattr(e, 'strerror', None) or e})") from None


def add_options_argument(parser: argparse.ArgumentParser, kind: type[msgspec.Struct]) -> None:
    """Adds ``--options JSON``: the role's whole configuration (a ``kind``) as one JSON object.

    The role's flags are added with ``dest=option(FIELD)`` and ``default=argparse.SUPPRESS``, so
    :func:`options_from_args` knows which field each fills and which ones were given.
    """
    parser.add_argument(
        "--options",
        metavar="JSON",
        help=f"every option at once, a JSON object with the fields of {kind.__module__}.{kind.__name__} "
        "(what iwz run passes), or @FILE holding it; flags given beside it override it",
    )


def options_from_args(args: argparse.Namespace, kind: type[S], base: S | None = None) -> S:
    """A role's options: ``base`` (or ``--options``, or the defaults), then the flags given.

    Args:
        args: Parsed arguments whose role flags have ``dest=option(FIELD)`` and
            ``default=argparse.SUPPRESS``.
        kind: The options Struct.
        base: Options to start from instead of ``args.options``.

    Returns:
        The options, validated by msgspec (types and ranges of ``kind``).

    Raises:
        IwError: Naming the option (its JSON path) and the reason.
    """
    try:
        if base is None and getattr(args, "options", None):
            base = msgspec.json.decode(_options_text(args.options), type=kind)
        start: dict[str, Any] = msgspec.structs.asdict(base) if base is not None else {}
        given = {f: getattr(args, option(f)) for f in kind.__struct_fields__ if hasattr(args, option(f))}
        return msgspec.convert(msgspec.to_builtins({**start, **given}), kind)
    except msgspec.DecodeError as e:  # ValidationError is one
        raise IwError(f"refused options: {e}") from None
