"""The scene schema's machinery: each key declared once, on its section's dataclass field.

A section is a frozen dataclass; each field that is a scene key carries its metadata through
`key`::

    nu: float = field(default=0.01, metadata=key("coefficient of the viscous term of (6.2)
        [m^(3/2)/s]", nonneg=True))

Its default is the field's default, its type the field's annotation (``float``, ``int``,
``bool``, ``str``, ``tuple[float, ...]``, each possibly ``| None``); the metadata adds the range
or the choices (a callable, so a registry is read when a scene is read and a law that user code
registers is a valid choice), the doc text of the scenes reference and whether the kernels are
compiled for the value. Fields without it (derived values such as ``FlowConfig.F``) are no keys.

From that one declaration come: the generic reader (`read_section`, one typed and checked
read per field, in field order), the writer (`write_section`), the allowed keys
(`key_names`), the compiled keys (`compiled_keys`) and the reference page
(`tiseg.setup.reference`). The rules that tie several keys together are explicit validators
after the generic read (`tiseg.setup.validators`).
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Mapping

from ..errors import InputError
from .table import MISSING, Table, type_name

KEY = "tiseg.key"  # the metadata entry of a scene key
DECLARED = object()  # read_key's default: the field's own


@dataclass(frozen=True)
class Key:
    """What one scene key is, besides its name, type and default (those are the field's).

    ``lo``/``hi``: inclusive bounds; ``positive`` (> 0) and ``nonneg`` (>= 0) give their own
    messages. ``choices``: the allowed words, a callable read at each use (a registry) or a
    tuple; ``order``: registered words to list first, in this order (messages, pages);
    ``aliases``: other spellings taken for a choice. ``compiled``: the kernels are built for
    the value, through the operator's configuration ("operator", whose compiled fields say
    which) or by the simulation itself ("simulation": stepper, stages, precision); a change of
    either needs a new Simulation. ``table``: the key is a sub-table declared by that
    dataclass (``material.small``). ``kinds``: the ``initial.kind`` values that use the key;
    ``read_default``: the default those kinds read (a value, a callable of the scene read so
    far, MISSING for a required key), where the field's own default is None for the others.
    ``write``: whether the writer writes the value (given the section's value and the scene);
    None values are never written (TOML has no null). ``units``: the value's unit in UDUNITS
    form ("1" for a pure number), where the doc's trailing ``[unit]`` does not give it.
    ``many``: with ``table``, an array of such tables (``[[output.gauges]]``), a tuple of
    values; left out of the written scene when empty."""

    doc: str
    lo: float | None = None
    hi: float | None = None
    positive: bool = False
    nonneg: bool = False
    allow_inf: bool = False
    choices: Callable[[], Iterable[str]] | tuple[str, ...] | None = None
    order: tuple[str, ...] = ()
    aliases: Mapping[str, str] | None = None
    compiled: str | None = None
    table: type | None = None
    kinds: tuple[str, ...] = ()
    read_default: Any = None
    write: Callable[[Any, Any], bool] | None = None
    units: str | None = None
    many: bool = False

    def allowed(self) -> tuple[str, ...]:
        """The allowed words now (the registry as it stands)."""
        c = self.choices
        now = tuple(c() if callable(c) else c or ())
        return tuple(w for w in self.order if w in now) + tuple(
            w for w in now if w not in self.order
        )

    def range_text(self) -> str:
        """The range in words for the reference page ('' when unbounded)."""
        if self.positive:
            return "> 0"
        if self.nonneg:
            return ">= 0"
        if self.lo is not None and self.hi is not None:
            return f"[{self.lo:g}, {self.hi:g}]"
        if self.lo is not None:
            return f">= {self.lo:g}"
        if self.hi is not None:
            return f"<= {self.hi:g}"
        return ""


# the units that docs write in brackets, as UDUNITS spells them (CF's units attribute)
DOC_UNITS = {
    "m": "m",
    "s": "s",
    "m/s": "m s-1",
    "m/s^2": "m s-2",
    "1/s": "s-1",
    "m^(3/2)/s": "m1.5 s-1",
    "degrees": "degree",
    "Hz": "Hz",
}


def units_of(f: dataclasses.Field) -> str | None:
    """The unit of a number key in UDUNITS form (a sweep's sampled or gridded key gets it as its
    CF units): the declared ``units``, else the unit in the doc's trailing brackets
    ("slope angle zeta [degrees]"; brackets that hold a range, "[0, 1]", are not units), else
    None (not declared)."""
    k = key_of(f)
    if k is None:
        return None
    if k.units is not None:
        return k.units
    found = [
        DOC_UNITS[b.strip()] for b in re.findall(r"\[([^\]]*)\]", k.doc) if b.strip() in DOC_UNITS
    ]
    return found[0] if found else None


def key(doc: str, **meta) -> dict:
    """The metadata of a field that is a scene key (see `Key`)."""
    return {KEY: Key(doc, **meta)}


def key_of(f: dataclasses.Field) -> Key | None:
    return f.metadata.get(KEY)


def key_fields(cls) -> list[dataclasses.Field]:
    """The fields of ``cls`` that are scene keys, in declaration order."""
    return [f for f in dataclasses.fields(cls) if KEY in f.metadata]


def key_names(cls) -> tuple[str, ...]:
    return tuple(f.name for f in key_fields(cls))


def field_named(cls, name: str) -> dataclasses.Field:
    return next(f for f in key_fields(cls) if f.name == name)


def default_of(f: dataclasses.Field):
    """The declared default, or `MISSING` for a required key."""
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return MISSING


def kind_of(f: dataclasses.Field) -> str:
    """number, integer, boolean, choice, string, numbers or choices (an array of distinct
    allowed words), from the annotation."""
    base = str(f.type).split("|")[0].strip()
    if base == "float":
        return "number"
    if base == "int":
        return "integer"
    if base == "bool":
        return "boolean"
    if base == "str":
        return "choice" if key_of(f).choices is not None else "string"
    if base.startswith("tuple[float"):
        return "numbers"
    if base.startswith("tuple[str"):
        return "choices"
    raise TypeError(f"scene key {f.name}: no reader for the type {f.type!r}")


def read_key(t: Table, f: dataclasses.Field, default=DECLARED):
    """One key of table ``t`` as field ``f`` declares it: typed and checked, or its default
    (the declared one unless ``default`` is given; None is a default too, MISSING makes the
    key required)."""
    k = key_of(f)
    d = default_of(f) if default is DECLARED else default
    if d is None and not t.has(f.name):
        return None  # an optional key left out
    kind = kind_of(f)
    if kind == "number":
        return t.number(
            f.name,
            d,
            positive=k.positive,
            nonneg=k.nonneg,
            lo=k.lo,
            hi=k.hi,
            allow_inf=k.allow_inf,
        )
    if kind == "integer":
        return t.integer(f.name, d, lo=k.lo)
    if kind == "boolean":
        return t.boolean(f.name, d)
    if kind == "choice":
        return t.choice(f.name, k.allowed(), d, aliases=k.aliases)
    if kind == "string":
        return t.string(f.name, d)
    if kind == "choices":
        return tuple(t.choice_list(f.name, k.allowed(), d))
    return tuple(t.number_list(f.name, d))


def read_section(cls, t: Table, defaults: Mapping[str, Any] | None = None, skip=()) -> dict:
    """{name: value} of every key field of ``cls`` (but ``skip``), read from ``t`` in
    declaration order; ``defaults`` replaces declared defaults that depend on other sections
    (inflow.h defaults to flow.h0)."""
    defaults = defaults or {}
    return {
        f.name: read_key(t, f, defaults.get(f.name, DECLARED))
        for f in key_fields(cls)
        if f.name not in skip and key_of(f).table is None
    }


def constant_field(c) -> dataclasses.Field:
    """A friction law's `tiseg.model.physics.friction.Constant` as the field of a number key,
    so that it is read, written and documented like the section's own keys."""
    f = dataclasses.field(
        default=c.default,
        metadata=key(c.doc, lo=c.lo, hi=c.hi, positive=c.positive, nonneg=c.nonneg),
    )
    f.name, f.type = c.name, "float"
    return f


def plain(v):
    """A value as TOML writes it: tuples become arrays."""
    return list(v) if isinstance(v, tuple) else v


def write_section(cls, value, scene=None) -> dict:
    """The keys of one section's ``value`` as its TOML table: every key field in declaration
    order, leaving out None (TOML has no null) and keys whose ``write`` rule says no."""
    out = {}
    for f in key_fields(cls):
        k = key_of(f)
        v = getattr(value, f.name)
        if v is None or (k.write is not None and not k.write(value, scene)):
            continue
        if k.table is not None and k.many:
            if v:  # an array of tables; none: no key (TOML has no empty array of tables)
                out[f.name] = [write_section(k.table, item, scene) for item in v]
            continue
        out[f.name] = write_section(k.table, v, scene) if k.table is not None else plain(v)
    return out


def read_tables(t: Table, f: dataclasses.Field) -> tuple[dict, ...]:
    """The array of tables ``f`` declares (``many``), each read as its dataclass's keys (one
    dict per table, in order); none when the key is left out."""
    k = key_of(f)
    items = t.get(f.name, [])
    full = t.full(f.name)
    if not isinstance(items, (list, tuple)) or not all(isinstance(i, Mapping) for i in items):
        raise InputError(
            f"{full}: expected an array of tables ([[{full}]] entries), got {type_name(items)}"
        )
    names = key_names(k.table)
    return tuple(
        read_section(k.table, Table(item, f"{full}[{i}]", names)) for i, item in enumerate(items)
    )


def compiled_keys(sections: Mapping[str, type], how: str | None = None) -> tuple[str, ...]:
    """The dotted keys whose values the kernels are compiled for (``how``: only those compiled
    "operator" or "simulation")."""
    return tuple(
        f"{name}.{f.name}"
        for name, cls in sections.items()
        for f in key_fields(cls)
        if key_of(f).compiled and (how is None or key_of(f).compiled == how)
    )
