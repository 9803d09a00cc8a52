"""Typed reads from one TOML table, and the small helpers of reading TOML.

Every failure is a one-line `tiseg.errors.InputError` that names the full dotted key, the
bad value and what is allowed: an unknown key lists the allowed ones with the closest match, a
number out of its range says the range. A number written non-zero that a double cannot hold
(1e-400) is refused by the key that reads it (`Underflow`), not silently taken as 0.
"""

from __future__ import annotations

import difflib
import math
import numbers
import re
import sys
from typing import Iterable, Mapping

from ..errors import InputError

MAX_NESTING = 16  # levels of tables and arrays: a scene needs 3, a deeper one is refused

MISSING = object()  # no default: the key is required


class Table:
    """Typed reads from one TOML table; every failure is an InputError naming the full key.

    Unknown keys are rejected on construction, listing the allowed keys and the closest match.
    """

    def __init__(self, data: Mapping, prefix: str, allowed: Iterable[str]):
        self.data = data
        self.prefix = prefix
        self.allowed = tuple(allowed)
        for key in data:
            if key not in self.allowed:
                self._unknown(key)

    def _unknown(self, key) -> None:
        where = f"section [{self.prefix}]" if self.prefix else "the top level"
        full = self.full(key)
        close = difflib.get_close_matches(str(key), self.allowed, n=1, cutoff=0.5)
        hint = f" (did you mean {self.full(close[0])!r}?)" if close else ""
        what = "key" if self.prefix else "section or key"
        raise InputError(
            f"unknown {what} {full!r} in {where}{hint}; allowed: {', '.join(self.allowed)}"
        )

    def only(self, allowed: Iterable[str], because: str) -> None:
        """Reject keys that are valid for the section but not in this configuration."""
        allowed = tuple(allowed)
        for key in self.data:
            if key not in allowed:
                raise InputError(
                    f"{self.full(key)} is not used by {because} (its keys: "
                    f"{', '.join(allowed)}); remove it or change the kind"
                )

    def full(self, key: str) -> str:
        return f"{self.prefix}.{key}" if self.prefix else str(key)

    def has(self, key: str) -> bool:
        return key in self.data

    def get(self, key: str, default=MISSING):
        if key in self.data:
            return self.data[key]
        if default is MISSING:
            raise InputError(f"{self.full(key)} is required")
        return default

    def table(self, key: str, allowed: Iterable[str]) -> "Table":
        v = self.data.get(key, {})
        full = self.full(key)
        if not isinstance(v, Mapping):
            raise InputError(f"{full}={show(v)}: expected a table ([{full}]), got {type_name(v)}")
        return Table(v, full, allowed)

    def string(self, key: str, default=MISSING) -> str:
        v = self.get(key, default)
        if not isinstance(v, str):
            raise InputError(f"{self.full(key)}={show(v)}: expected a string, got {type_name(v)}")
        return v

    def boolean(self, key: str, default=MISSING) -> bool:
        v = self.get(key, default)
        if not isinstance(v, bool):
            raise InputError(
                f"{self.full(key)}={show(v)}: expected true or false, got {type_name(v)}"
            )
        return v

    def choice(
        self,
        key: str,
        choices: tuple[str, ...],
        default=MISSING,
        aliases: Mapping[str, str] | None = None,
    ) -> str:
        v = self.get(key, default)
        full = self.full(key)
        if not isinstance(v, str):
            raise InputError(
                f"{full}={show(v)}: expected a string, one of "
                f"{', '.join(map(repr, choices))}; got {type_name(v)}"
            )
        if aliases and v in aliases:
            return aliases[v]
        if v not in choices:
            close = difflib.get_close_matches(v, list(choices) + list(aliases or ()), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise InputError(
                f"{full}={v!r}: allowed values are {', '.join(map(repr, choices))}{hint}"
            )
        return v

    def number(
        self,
        key: str,
        default=MISSING,
        *,
        positive=False,
        nonneg=False,
        lo=None,
        hi=None,
        allow_inf=False,
    ) -> float | None:
        """A real number (int or float, never bool), finite unless ``allow_inf``; None only as
        a default. ``lo``/``hi`` are inclusive bounds."""
        v = self.get(key, default)
        if v is None and key not in self.data:
            return None
        full = self.full(key)
        if isinstance(v, bool) or not isinstance(v, numbers.Real):
            raise InputError(f"{full}={show(v)}: expected a number, got {type_name(v)}")
        check_underflow(full, v)
        f = float(v)
        if math.isnan(f) or (math.isinf(f) and not (allow_inf and f > 0)):
            raise InputError(f"{full}={show(v)}: must be a finite number")
        if positive and not f > 0:
            raise InputError(f"{full}={show(v)}: must be positive (> 0)")
        if nonneg and not f >= 0:
            raise InputError(f"{full}={show(v)}: must not be negative")
        if lo is not None and hi is not None and not lo <= f <= hi:
            raise InputError(f"{full}={show(v)}: must lie in [{lo:g}, {hi:g}]")
        if lo is not None and not f >= lo:
            raise InputError(f"{full}={show(v)}: must be >= {lo:g}")
        if hi is not None and not f <= hi:
            raise InputError(f"{full}={show(v)}: must be <= {hi:g}")
        return f

    def integer(self, key: str, default=MISSING, *, lo=None) -> int:
        v = self.get(key, default)
        full = self.full(key)
        if isinstance(v, bool) or not isinstance(v, numbers.Integral):
            raise InputError(f"{full}={show(v)}: expected an integer, got {type_name(v)}")
        i = int(v)
        if lo is not None and i < lo:
            raise InputError(f"{full}={i}: must be an integer >= {lo}")
        return i

    def choice_list(self, key: str, choices: tuple[str, ...], default=MISSING) -> list[str]:
        """An array of distinct words, each one of ``choices``."""
        v = self.get(key, default)
        full = self.full(key)
        if not isinstance(v, (list, tuple)):
            raise InputError(
                f"{full}={show(v)}: expected an array of names such as "
                f"[{', '.join(map(repr, choices[:1] or ('name',)))}], got {type_name(v)}"
            )
        out: list[str] = []
        for i, x in enumerate(v):
            word = Table({f"{key}[{i}]": x}, self.prefix, (f"{key}[{i}]",)).choice(
                f"{key}[{i}]", choices
            )
            if word in out:
                raise InputError(f"{full}={show(v)}: {word!r} is named twice")
            out.append(word)
        return out

    def number_list(self, key: str, default=MISSING) -> list[float]:
        v = self.get(key, default)
        full = self.full(key)
        if not isinstance(v, (list, tuple)):
            raise InputError(
                f"{full}={show(v)}: expected an array of numbers such as "
                f"[1.0, 2.5], got {type_name(v)}"
            )
        out = []
        for i, x in enumerate(v):
            if isinstance(x, bool) or not isinstance(x, numbers.Real) or not math.isfinite(x):
                raise InputError(
                    f"{full}[{i}]={show(x)}: expected a finite number, got {type_name(x)}"
                )
            check_underflow(f"{full}[{i}]", x)
            out.append(float(x))
        return out


class Underflow(float):
    """A number written non-zero whose double is 0.0 or subnormal (1e-400, 1e-310), as TOML
    reads it. It keeps its text, so that the key reading it refuses it by name: taken as it is,
    flow.nu = 1e-400 would be 0 and switch the viscosity off without a word."""

    text: str

    def __new__(cls, value: float, text: str):
        obj = super().__new__(cls, value)
        obj.text = text
        return obj


def toml_float(text: str) -> float:
    """tomllib's parse_float: the float of a TOML literal, an `Underflow` when a
    non-zero literal (a digit 1-9 before its exponent) does not survive as a normal double."""
    v = float(text)
    if not math.isfinite(v) or abs(v) >= sys.float_info.min:
        return v
    if v == 0.0 and not re.search(r"[1-9]", re.split(r"[eE]", text)[0]):
        return v  # written as zero: 0.0, -0e5
    return Underflow(v, text)


def check_underflow(key: str, v) -> None:
    if isinstance(v, Underflow):
        raise InputError(
            f"{key}={v.text}: smaller than the smallest normal double "
            f"({sys.float_info.min:.3g}), it would be read as {float(v)!r}; write 0 for zero"
        )


def deep_copy(v, where: str = "", depth: int = 0):
    """A copy of nested tables and arrays, refused past MAX_NESTING levels (which the
    recursion would otherwise meet as a RecursionError traceback); ``where``: the key path."""
    if depth > MAX_NESTING:
        raise InputError(
            f"{where if len(where) <= 60 else where[:57] + '...'}: tables or arrays nest more than {MAX_NESTING} levels deep "
            "(a scene needs at most 3, as in material.small.zeta1_deg)"
        )
    if isinstance(v, Mapping):
        return {
            k: deep_copy(x, f"{where}.{k}" if where else str(k), depth + 1) for k, x in v.items()
        }
    if isinstance(v, (list, tuple)):
        return [deep_copy(x, f"{where}[{i}]", depth + 1) for i, x in enumerate(v)]
    return v


def require(cond: bool, key: str, value, rule: str) -> None:
    if not cond:
        raise InputError(f"{key}={show(value)}: {rule}")


def show(v) -> str:
    s = repr(v)
    return s if len(s) <= 60 else s[:57] + "..."


def type_name(v) -> str:
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, numbers.Integral):
        return "an integer"
    if isinstance(v, numbers.Real):
        return "a float"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, (list, tuple)):
        return "an array"
    if isinstance(v, Mapping):
        return "a table"
    return f"a {type(v).__name__}"  # e.g. TOML dates and times


def close(a: float, b: float, rel: float = 1e-9) -> bool:
    return abs(a - b) <= rel * max(abs(a), abs(b))


def near_integer(x: float | None, rel: float = 1e-6) -> bool:
    return x is not None and round(x) >= 1 and abs(x - round(x)) <= rel * max(1.0, abs(x))
