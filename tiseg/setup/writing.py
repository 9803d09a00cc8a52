"""A resolved scene as the nested dict of its TOML form, written from the declarations.

Every section is written key by key in declaration order by
`tiseg.setup.schema.write_section` (None left out, as TOML has no null); two tables say
more than their values: the domain writes the resolution instead of the cell counts it derives
(so that an override of Lx or Ly on the resolved scene re-derives them), and the initial state
writes the keys of its kind only. ``load_scene`` of the TOML gives an equal scene.
"""

from __future__ import annotations

from .bed import terrain_to_dict
from .schema import plain, write_section
from .sections import (
    BoundaryConfig,
    FlowConfig,
    InflowConfig,
    NumericsConfig,
    OutputConfig,
    SpeciesKeys,
    TimeConfig,
    effects_fields,
    initial_keys,
    material_fields,
)


def _fields_of(fields, value) -> dict:
    out = {}
    for f in fields:
        # (a constant of a source term that is off has no value: no key)
        v = getattr(value, f.name, None)
        if v is not None:
            out[f.name] = plain(v)
    return out


def _material(m) -> dict:
    out = {}
    for f in material_fields():
        if f.name in ("small", "large"):
            out[f.name] = write_section(SpeciesKeys, getattr(m, f.name))
        else:
            out[f.name] = getattr(m, f.name)
    return out


def _domain(dom) -> dict:
    # With a resolution the cell counts are derived from it (and left out, so that an override
    # of Lx or Ly on the resolved scene re-derives them); a 1D run keeps its explicit ny = 1.
    domain = {"Lx": dom.Lx, "Ly": dom.Ly}
    if dom.resolution is not None:
        domain["resolution"] = dom.resolution
    else:
        domain["nx"] = dom.nx
    if dom.resolution is None or dom.is_1d:
        domain["ny"] = dom.ny
    return domain


def scene_to_dict(scene, derived: bool = False) -> dict:
    """The resolved scene as the nested dict of its TOML form (None values are left out, as TOML
    has no null). With ``derived=True`` a ``derived`` table with u0, F, dx, dy, the output times
    and the resolved switches is added (that dict is for reports, not for loading)."""
    d: dict = {
        "name": scene.name,
        "description": scene.description,
        "material": _material(scene.material),
        "flow": write_section(FlowConfig, scene.flow, scene),
        "effects": _fields_of(effects_fields(), scene.effects),
        "domain": _domain(scene.domain),
        "boundary": write_section(BoundaryConfig, scene.boundary),
    }
    if scene.inflow is not None:
        inflow = write_section(InflowConfig, scene.inflow)
        if "stop_time" in inflow:  # last, where scene.toml files have always had it
            inflow["stop_time"] = inflow.pop("stop_time")
        d["inflow"] = inflow
    ini = scene.initial
    d["initial"] = {
        k: getattr(ini, k) for k in initial_keys()[ini.kind] if getattr(ini, k) is not None
    }
    terrain = terrain_to_dict(scene.terrain)
    if terrain is not None:  # a flat plane writes no section (scenes of before stay the same)
        d["terrain"] = terrain
    d["numerics"] = write_section(NumericsConfig, scene.numerics)
    d["time"] = write_section(TimeConfig, scene.time)
    d["output"] = write_section(OutputConfig, scene.output)
    if derived:
        der = {
            "dx": scene.dx,
            "dy": scene.dy,
            "is_1d": scene.is_1d,
            "viscous": scene.viscous,
            "feedback": scene.feedback,
            "fields": list(scene.fields),
            "output_times": list(scene.output_times),
        }
        if scene.flow.u0 is not None:
            der.update(
                u0=scene.flow.u0,
                F=scene.flow.F,
                time_scale=scene.time_scale,
                reynolds=scene.reynolds,
            )
        d["derived"] = der
    return d
