"""The JSON Schema a channel is written with: one that Foxglove's and Lichtblick's parsers accept.

msgspec writes JSON Schema 2020-12 with a root ``$ref`` into ``$defs``, ``prefixItems`` tuples,
``anyOf`` for optional fields and bare ``enum`` lists. Lichtblick (and Foxglove's open-source
studio) read a channel's schema with their own parser (``parseJsonSchema.ts``, rules in
docs/recording.md), which throws on all of those and then drops the channel. :func:`portable`
rewrites such a schema, keeping every constraint it checks:

* every ``$ref`` inlined, no ``$defs``: the schema stands alone;
* ``$schema`` declared draft-07, so a validator in its default mode (Ajv, jsonschema's
  ``validator_for``) checks it by the right rules; nothing in it reads differently in 2020-12;
* an ``enum`` carries the ``type`` of its values;
* a tuple (``prefixItems``) becomes an array with one item schema and its length (``minItems`` =
  ``maxItems``), the item schema the one its members share or ``anyOf`` of theirs;
* an object property the parsers cannot type (an optional ``anyOf`` with ``null``, an array of
  arrays...) is moved from ``properties`` to ``patternProperties`` (``^name$``), which validators
  apply and those parsers ignore: the channel opens, the field shows in the raw message, and a
  validator still checks it.

Pure: dictionaries in, dictionaries out.
"""

from __future__ import annotations

import copy
import re
from typing import Any

__all__ = ["DRAFT_07", "consumer_typed", "portable"]

DRAFT_07 = "http://json-schema.org/draft-07/schema#"
_SCALARS = ("boolean", "string", "number", "integer")  # what the parsers type, beside object and array
_JSON_TYPE = {bool: "boolean", str: "string", int: "integer", float: "number"}


def portable(schema: dict[str, Any]) -> dict[str, Any]:
    """The self-contained, draft-07-declared form of a msgspec JSON Schema (see the module).

    Args:
        schema: The schema as ``msgspec.json.schema`` writes it (not modified).

    Returns:
        A new schema: root ``type: object``, no ``$ref``, ``$schema`` draft-07.

    Raises:
        KeyError: A ``$ref`` names no entry of ``$defs``.
    """
    defs: dict[str, Any] = schema.get("$defs", {})
    out = _inline(schema, defs)
    out.pop("$defs", None)
    return {"$schema": DRAFT_07, **out}


def consumer_typed(prop: dict[str, Any]) -> bool:
    """Whether Lichtblick's and Foxglove's parsers type the property schema ``prop`` (one of the
    rules of docs/recording.md; an object's own properties are made to follow them apart)."""
    kind = prop.get("type")
    if "oneOf" in prop:
        return all(isinstance(alt, dict) and isinstance(alt.get("const"), (int, float)) for alt in prop["oneOf"])
    if kind in ("boolean", "number", "integer", "object"):
        return True
    if kind == "string":
        return prop.get("contentEncoding") in (None, "base64")
    if kind == "array":
        items = prop.get("items")
        if not isinstance(items, dict):
            return False
        if items.get("type") == "string":
            return "contentEncoding" not in items
        return items.get("type") in (*_SCALARS, "object")
    return False


def _resolve(s: dict[str, Any], defs: dict[str, Any]) -> dict[str, Any]:
    while "$ref" in s:
        target = defs[s["$ref"].rsplit("/", 1)[-1]]
        s = {**target, **{k: v for k, v in s.items() if k != "$ref"}}
    return s


def _inline(s: dict[str, Any], defs: dict[str, Any]) -> dict[str, Any]:
    s = _resolve(s, defs)
    out: dict[str, Any] = {}
    for k, v in s.items():
        if k in ("properties", "patternProperties", "$defs"):
            continue
        if k in ("items", "additionalProperties", "not") and isinstance(v, dict):
            out[k] = _inline(v, defs)
        elif k in ("anyOf", "oneOf", "allOf", "prefixItems") and isinstance(v, list):
            out[k] = [_inline(x, defs) for x in v]
        else:
            out[k] = copy.deepcopy(v)
    if "enum" in out and "type" not in out:
        kinds = {_JSON_TYPE.get(type(v)) for v in out["enum"]}
        if len(kinds) == 1 and None not in kinds:
            out["type"] = kinds.pop()
    if "prefixItems" in out:
        _tuple_as_array(out)
    props = {name: _inline(p, defs) for name, p in s.get("properties", {}).items()}
    if props or s.get("type") == "object":
        typed = {n: p for n, p in props.items() if consumer_typed(p)}
        untyped = {f"^{re.escape(n)}$": p for n, p in props.items() if n not in typed}
        out["type"] = "object"
        out["properties"] = typed
        if untyped:
            out["patternProperties"] = untyped
    return out


def _tuple_as_array(out: dict[str, Any]) -> None:
    """A ``prefixItems`` tuple as an array of one item schema and a fixed length (draft-07 and
    2020-12 read it the same)."""
    members: list[dict[str, Any]] = out.pop("prefixItems")
    if out.get("items") is False:
        out.pop("items")
    distinct: list[dict[str, Any]] = []
    for m in members:
        if m not in distinct:
            distinct.append(m)
    out["items"] = distinct[0] if len(distinct) == 1 else {"anyOf": distinct}
    out["minItems"] = out["maxItems"] = len(members)
