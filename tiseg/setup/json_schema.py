"""The scene schema as a JSON Schema (draft 2020-12), for editors.

TOML editors that read JSON Schemas (Taplo and the VS Code extension "Even Better TOML",
which associate one with a file through a ``#:schema`` comment or their settings) then complete
the keys of a scene, show each key's doc and refuse an unknown key, a wrong type, a value out
of range or a word that is not a choice, as you type. ``tiseg scenes schema > scene.schema.json``
writes it.

It is built from the same declarations as the reader (`tiseg.setup.schema`,
`tiseg.setup.sections`), so it follows them; the registries (friction laws, steppers) are read
when it is built. What no single key can say (a key needed only with another, a range that
depends on another key, the keys an ``initial.kind`` takes) stays with the validators of
`tiseg.setup.validators`: a scene this schema accepts can still be refused by ``tiseg run``,
with a message; one it refuses, ``tiseg run`` refuses too.
"""

from __future__ import annotations

import dataclasses
import math

from .schema import default_of, key_fields, key_of, kind_of
from .sections import SECTIONS, section_fields
from .table import MISSING

DIALECT = "https://json-schema.org/draft/2020-12/schema"


def scene_schema() -> dict:
    """The JSON Schema of a scene file (a dict, ready for ``json.dumps``)."""
    return {
        "$schema": DIALECT,
        "title": "tiseg scene",
        "description": "A scene of tiseg: the experiment, its grid, numerics and output "
        "(see the scenes reference of the documentation).",
        "type": "object",
        "properties": {
            "name": {"type": "string", "description": "the scene's name"},
            "description": {"type": "string", "description": "one line on what it shows"},
            **{s: _table(section_fields(s), f"[{s}]") for s in SECTIONS},
        },
        "additionalProperties": False,
    }


def _table(fields: list[dataclasses.Field], description: str) -> dict:
    return {
        "type": "object",
        "description": description,
        "properties": {f.name: _key(f) for f in fields},
        "additionalProperties": False,
    }


def _key(f: dataclasses.Field) -> dict:
    k = key_of(f)
    if k.table is not None:  # a sub-table (material.small) or an array of them (gauges)
        table = _table(key_fields(k.table), k.doc)
        if not k.many:
            return table
        return {"type": "array", "description": k.doc, "items": table}
    out: dict = {"description": k.doc}
    kind = kind_of(f)
    if kind in ("number", "integer"):
        out["type"] = kind
        # the reader's bounds, as Table.number and Table.integer check them
        if k.positive:
            out["exclusiveMinimum"] = 0
        elif k.nonneg:
            out["minimum"] = 0
        if k.lo is not None:
            out["minimum"] = k.lo
        if k.hi is not None and kind == "number":
            out["maximum"] = k.hi
    elif kind == "boolean":
        out["type"] = "boolean"
    elif kind == "choice":
        out["enum"] = [*k.allowed(), *(k.aliases or {})]
    elif kind == "string":
        out["type"] = "string"
    elif kind == "choices":  # distinct registered words (Table.choice_list)
        out["type"] = "array"
        out["items"] = {"enum": list(k.allowed())}
        out["uniqueItems"] = True
    else:  # numbers
        out["type"] = "array"
        out["items"] = {"type": "number"}
    default = _json_default(default_of(f))
    if default is not None:
        out["default"] = default
    return out


def _json_default(v):
    """The default as JSON holds it, or None where there is none to show (a required key, a
    default that depends on other keys, infinity)."""
    if v is MISSING or v is None or dataclasses.is_dataclass(v):
        return None
    if isinstance(v, tuple):
        return [_json_default(x) for x in v] if v else None
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v
