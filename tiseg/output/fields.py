"""The output fields, each declared once: its name, how it is computed, its CF attributes and
how the pictures show it.

A `FieldSpec` is read by every part that meets the field: the fields writer
(`tiseg.output.netcdf.FieldsWriter`: which variables exist, their attributes, what is missing),
the run folder (`tiseg.run.run_folder`: what a run writes, computed from the primitive fields of
each snapshot), the readers (`FieldsWriter.append`, the peak grids), and the renderer and the
viewer (labels, units, colour map: `tiseg.post.render.colours`).

Three kinds:

* ``"snapshot"``: a variable (time, y, x) written at every output time. The primitive fields
  ``h, u, v, phi`` come from the state; a spec with ``compute`` is computed from them, so adding
  an output field is one `register_field` call (a test registers one from its own file and
  reads it back);
* ``"peak"``: a 2D variable (y, x) without a time axis, the peak fields of `tiseg.run.peaks`;
* ``"shown"``: shown by the pictures, computed from the stored fields when drawn, never stored
  (the speed |u|).
* ``"static"``: a 2D variable (y, x) written once when the file is made, computed from the
  scene (``compute(scene)``, None where the run has none): the terrain's bed ``b`` and its
  ``solid`` mask, only in runs with a ``[terrain]``, so a flat run's file has no such variable.

`OUTPUT_FIELDS` is the registry, read when asked: a field registered by user code after import
is written by the next run that has the fields it needs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

KINDS = ("snapshot", "peak", "shown", "static")


@dataclass(frozen=True)
class FieldSpec:
    """One output field.

    ``attrs``: its CF attributes (``long_name``, ``units``, ``comment``, ``cell_methods``).
    ``needs``: the primitive fields it is computed from (a run without one of them lacks it:
    ``v`` needs 2D, ``phi`` segregation). ``compute``: ``(primitive fields) -> (ny, nx) array``
    for a computed snapshot field (None: a primitive or peak field, given by the state); for a
    static field ``(scene) -> (ny, nx) array or None`` (None: the run has no such field).
    ``dtype``: a static field's NetCDF type ("f8", "i1"; None: the file's).
    ``missing_where_dry``: stored as missing where h < h_min (there is no material to have a
    value). ``label``, ``factor``, ``unit``, ``short``: how pictures show it (axis label, value
    x factor in unit, the ASCII caption); ``colours``: ``"phi"`` (the experiment's
    coarse-to-fines blend) or ``"viridis"``."""

    name: str
    attrs: Mapping[str, str]
    kind: str = "snapshot"
    needs: tuple[str, ...] = ()
    compute: Callable[[Mapping[str, np.ndarray]], np.ndarray] | None = None
    missing_where_dry: bool = False
    label: str = ""
    factor: float = 1.0
    unit: str = ""
    short: str = ""
    colours: str = "viridis"
    dtype: str | None = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"FieldSpec {self.name!r}: kind={self.kind!r}, choose one of {KINDS}")

    def present(self, primitives) -> bool:
        """Whether a run whose state gives the fields ``primitives`` has this field."""
        return all(n in primitives for n in (self.needs or (self.name,)))


OUTPUT_FIELDS: dict[str, FieldSpec] = {}


def register_field(spec: FieldSpec) -> FieldSpec:
    """Add (or replace) ``spec`` in `OUTPUT_FIELDS`."""
    OUTPUT_FIELDS[spec.name] = spec
    return spec


def specs(kind: str) -> dict[str, FieldSpec]:
    """The registered fields of ``kind``, in registry order (read now)."""
    return {n: s for n, s in OUTPUT_FIELDS.items() if s.kind == kind}


def snapshot_fields(primitives) -> tuple[str, ...]:
    """The snapshot variables of a run whose state gives ``primitives`` (h, u[, v][, phi]):
    those, in their order, then every computed field whose inputs the run has."""
    computed = tuple(
        n
        for n, s in specs("snapshot").items()
        if s.compute is not None and n not in primitives and s.present(primitives)
    )
    return tuple(primitives) + computed


def with_computed(primitives: Mapping[str, np.ndarray], names) -> dict[str, np.ndarray]:
    """The arrays of the variables ``names`` from the primitive fields of one snapshot."""
    out = {}
    for n in names:
        out[n] = primitives[n] if n in primitives else OUTPUT_FIELDS[n].compute(primitives)
    return out


def peak_variables(segregation: bool) -> tuple[str, ...]:
    """The 2D variables of a run that keeps peak fields (deposit_phi only with segregation)."""
    have = ("h", "u") + (("phi",) if segregation else ())
    return tuple(n for n, s in specs("peak").items() if s.present(have))


def static_fields(scene) -> dict[str, np.ndarray]:
    """{name: (ny, nx) array} of the registered static fields that ``scene`` has (read now)."""
    out = {}
    for n, s in specs("static").items():
        a = s.compute(scene)
        if a is not None:
            out[n] = a
    return out


def _bed(scene):
    # the scene's arrays are (nx, ny) on the cell centres; the file's (y, x)
    return scene.bed_arrays()[0].T if scene.has_terrain else None


def _solid(scene):
    return scene.bed_arrays()[1].T.astype("i1") if scene.has_terrain else None


def _speed(f):
    return np.hypot(f["u"], f["v"]) if "v" in f else np.abs(f["u"])


for _spec in (
    # the primitive fields of (6.1)-(6.3)
    FieldSpec(
        "h",
        {"long_name": "flow thickness", "units": "m"},
        label="thickness h",
        factor=1e3,
        unit="mm",
        short="h [mm]",
    ),
    FieldSpec(
        "u",
        {"long_name": "depth-averaged downslope velocity", "units": "m s-1"},
        label="downslope velocity u",
        unit="m/s",
        short="u [m/s]",
    ),
    FieldSpec(
        "v",
        {"long_name": "depth-averaged cross-slope velocity", "units": "m s-1"},
        label="cross-slope velocity v",
        unit="m/s",
        short="v [m/s]",
    ),
    FieldSpec(
        "phi",
        {"long_name": "depth-averaged small-particle concentration", "units": "1"},
        missing_where_dry=True,
        label="concentration φ",
        short="phi",
        colours="phi",
    ),
    FieldSpec(
        "speed",
        {"long_name": "depth-averaged speed", "units": "m s-1"},
        kind="shown",
        needs=("u",),
        compute=_speed,
        label="speed |u|",
        unit="m/s",
        short="|u| [m/s]",
    ),
    # the terrain (tiseg.setup.bed): static, in runs with a [terrain] only
    FieldSpec(
        "b",
        {
            "long_name": "bed height normal to the reference plane",
            "units": "m",
            "comment": "x runs down the inclined reference plane, y across it; the free "
            "surface is at b + h; 0 in solid cells",
        },
        kind="static",
        compute=_bed,
        label="bed b",
        factor=1e3,
        unit="mm",
        short="b [mm]",
        dtype="f8",
    ),
    FieldSpec(
        "solid",
        {
            "long_name": "solid cells of the terrain (walls: no material)",
            "units": "1",
            "flag_values": np.array([0, 1], dtype="i1"),
            "flag_meanings": "open solid",
        },
        kind="static",
        compute=_solid,
        label="solid",
        short="solid",
        dtype="i1",
    ),
    # the peak fields (tiseg.run.peaks)
    FieldSpec(
        "h_max",
        {
            "long_name": "largest flow thickness over the step states",
            "units": "m",
            "cell_methods": "time: maximum",
            "comment": "over the simulated time from 0 to peak_time",
        },
        kind="peak",
        needs=("h",),
        label="peak thickness h_max",
        factor=1e3,
        unit="mm",
    ),
    FieldSpec(
        "speed_max",
        {
            "long_name": "largest depth-averaged speed over the step states where h >= h_min",
            "units": "m s-1",
            "cell_methods": "time: maximum",
            "comment": "over the simulated time from 0 to peak_time; missing where the flow "
            "never reached the cell",
        },
        kind="peak",
        needs=("u",),
        label="peak speed",
        unit="m/s",
    ),
    FieldSpec(
        "arrival_time",
        {
            "long_name": "time of arrival of the flow, the first step state where h >= h_min",
            "units": "s",
            "comment": "seconds since t = 0 of the run; missing where the flow never came",
        },
        kind="peak",
        needs=("h",),
        label="arrival time",
        unit="s",
    ),
    FieldSpec(
        "deposit_h",
        {
            "long_name": "thickness of the material at rest at peak_time",
            "units": "m",
            "comment": "h where h >= h_min and the material is at rest, |u| <= 1e-06 m s-1 "
            "(tiseg.model.material.REST_SPEED); missing elsewhere",
        },
        kind="peak",
        needs=("h",),
        label="deposit thickness",
        factor=1e3,
        unit="mm",
    ),
    FieldSpec(
        "deposit_phi",
        {
            "long_name": "small-particle concentration of the material at rest at peak_time",
            "units": "1",
            "comment": "phi where deposit_h is given; missing elsewhere",
        },
        kind="peak",
        needs=("phi",),
        label="deposit φ",
        colours="phi",
    ),
):
    register_field(_spec)
del _spec
