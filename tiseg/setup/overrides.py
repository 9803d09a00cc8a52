"""Command-line style overrides (``--set section.key=value``), applied to the raw TOML data
before validation, so that an override is checked exactly like the same value in the file."""

from __future__ import annotations

import re
import tomllib
from typing import Any, Mapping

from ..errors import InputError
from .table import deep_copy, toml_float, type_name

KEY_PART = re.compile(r"^[A-Za-z0-9_-]+$")


def check_dotted_key(key, context) -> None:
    if not isinstance(key, str) or not key or not all(KEY_PART.match(p) for p in key.split(".")):
        raise InputError(
            f"override {context!r}: the key {key!r} must be dotted names such as "
            "'flow.h0' or 'material.small.zeta1_deg'"
        )


def apply_overrides(data: dict, overrides) -> None:
    """Apply ``section.key`` overrides to the raw scene dict in place (before validation)."""
    if overrides is None:
        return
    if isinstance(overrides, Mapping):
        items = []
        for key, value in overrides.items():
            check_dotted_key(key, key)
            items.append((key, value))
    elif isinstance(overrides, (list, tuple)):
        items = [parse_override(text) for text in overrides]
        seen: dict = {}
        for key, value in items:
            if key in seen:
                raise InputError(
                    f"--set {key} is given twice ({seen[key]!r} and {value!r}); give it once"
                )
            seen[key] = value
    else:
        raise InputError(
            f"overrides must be a dict or a list of 'section.key=value' strings, "
            f"got {type_name(overrides)}"
        )
    for key, value in items:
        parts = key.split(".")
        node = data
        for i, part in enumerate(parts[:-1]):
            nxt = node.get(part)
            if nxt is None:
                nxt = node[part] = {}
            elif not isinstance(nxt, dict):
                raise InputError(
                    f"override {key!r}: {'.'.join(parts[: i + 1])} is {type_name(nxt)}, not a table"
                )
            node = nxt
        if value is None:  # dict overrides only: remove the key
            node.pop(parts[-1], None)
        else:
            node[parts[-1]] = deep_copy(value, key, len(parts))


def parse_override(text: str) -> tuple[str, Any]:
    """Split ``"section.key=value"`` into the dotted key and the value parsed as a TOML literal.

    ``0.01`` -> float, ``3`` -> int, ``true`` -> bool, ``"weno"`` or a bare word ``weno`` ->
    str, ``[1.9, 3.3]`` -> list.
    """
    if not isinstance(text, str):
        raise InputError(f"override {text!r}: expected a string 'section.key=value'")
    key, sep, raw = text.partition("=")
    key, raw = key.strip(), raw.strip()
    if not sep:
        raise InputError(
            f"override {text!r}: expected 'section.key=value' (no '=' found; on the command "
            f"line: --set {text}=VALUE)"
        )
    check_dotted_key(key, text)
    if "\n" in raw or "\r" in raw:
        raise InputError(f"override {text!r}: the value must be on one line")
    try:
        doc = tomllib.loads(f"v = {raw}", parse_float=toml_float)
    except tomllib.TOMLDecodeError:
        return key, raw  # a bare word such as `weno`: take it as a string
    except RecursionError:
        raise InputError(f"override {key!r}: the value nests too deeply") from None
    if set(doc) != {"v"}:  # e.g. `1 \n x = 2` smuggling a second key
        return key, raw
    return key, doc["v"]
