"""The resolved scene: every section validated, every default filled in, one frozen value.

Build it with `tiseg.setup.scene.load_scene`; its properties are the switches and numbers the
run derives from the sections (``viscous``, ``feedback``, ``dx``, the Reynolds number (5.7)).
`build_labelled` turns the nested dict of a scene into a `Scene`, section by section; it lives
here, beside the class, because `Scene.with_overrides` builds a new scene as well (the reading
of files and names, `tiseg.setup.reading`, sits on top of both).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import tomli_w

from ..errors import InputError
from ..model.material import Material
from ..model.physics.friction import FRICTION_LAWS as LAWS
from ..output.paths import check_name, safe_name
from .bed import bed_arrays, check_initial, initial_thickness, read_terrain
from .overrides import apply_overrides
from .schema import read_section
from .sections import (
    BoundaryConfig,
    DomainConfig,
    EffectsConfig,
    FlowConfig,
    InflowConfig,
    InitialConfig,
    NumericsConfig,
    OutputConfig,
    TerrainConfig,
    TimeConfig,
    section_keys,
    top_level_keys,
)
from .table import Table
from .validators import (
    initial_kind,
    read_boundary,
    read_domain,
    read_effects,
    read_flow,
    read_inflow,
    read_initial,
    read_material,
    read_numerics,
    read_output,
)
from .writing import scene_to_dict


@dataclass(frozen=True)
class Scene:
    """A fully validated simulation set-up; build it with `load_scene`."""

    name: str
    description: str
    material: Material
    flow: FlowConfig
    effects: EffectsConfig
    domain: DomainConfig
    boundary: BoundaryConfig
    inflow: InflowConfig | None  # None unless boundary.x_lo == "inflow"
    initial: InitialConfig
    numerics: NumericsConfig
    time: TimeConfig
    output: OutputConfig
    terrain: TerrainConfig = TerrainConfig()  # no section: the flat plane
    source: str | None = field(default=None, compare=False)  # file it was read from

    # ---- resolved switches ------------------------------------------------------------------
    @property
    def segregation(self) -> bool:
        """Large-particle transport (6.3) is solved, i.e. there is a phi field."""
        return self.effects.segregation

    @property
    def viscous(self) -> bool:
        """The viscous term of (6.2) is present (switched on and nu > 0)."""
        return self.effects.viscosity and self.flow.nu > 0.0

    @property
    def acting_nu(self) -> float:
        """The viscosity nu of (6.2) that acts in the run [m^(3/2) s^-1]: flow.nu when
        `viscous`, else 0 (the reference flow keeps its nu for the scalings either way)."""
        return self.flow.nu if self.viscous else 0.0

    @property
    def feedback(self) -> bool:
        """Friction (3.4) depends on the local phi (segregation-mobility feedback)."""
        return (
            self.effects.segregation
            and self.effects.mobility_feedback
            and LAWS[self.effects.friction].weighted
        )

    @property
    def friction_phi(self) -> float:
        """Concentration the mixture friction uses where there is no feedback (flow.phi0)."""
        return self.flow.phi0

    @property
    def is_1d(self) -> bool:
        return self.domain.ny == 1

    @property
    def has_inflow(self) -> bool:
        return self.boundary.x_lo == "inflow"

    @property
    def periodic_x(self) -> bool:
        return self.boundary.x_lo == "periodic"

    @property
    def periodic_y(self) -> bool:
        return self.boundary.y_lo == "periodic"

    @property
    def has_terrain(self) -> bool:
        """A bed or solid cells from ``[terrain]`` (any shape or a raster); else the flat
        plane of the paper."""
        return self.terrain.has_terrain

    def bed_line(self):
        """The run-out's bed line (`tiseg.model.bed_line.BedLine`, x its arc length) from
        material.zeta_deg through ``[terrain.runout]``; None on a plane."""
        r = self.terrain.runout
        return None if r is None else r.line(self.material.zeta)

    def bed_arrays(self):
        """(b, solid) on the cell centres, (nx, ny) each: b float64, the bed height normal to
        the reference plane [m] (0 in solid cells), solid bool (walls, nodata). Cached and
        read-only (`tiseg.setup.bed.bed_arrays`); zeros and no solid cell without terrain."""
        return bed_arrays(self.terrain, self.domain)

    def initial_thickness(self):
        """The thickness raster of ``initial.kind = "file"`` on the cell centres (nx, ny) [m]
        (`tiseg.setup.bed.initial_thickness`)."""
        return initial_thickness(self.initial, self.domain)

    @property
    def fields(self) -> tuple[str, ...]:
        """Primitive output fields: h, u, v (2D only), phi (with segregation only)."""
        return ("h", "u") + (() if self.is_1d else ("v",)) + (("phi",) if self.segregation else ())

    # ---- derived numbers ---------------------------------------------------------------------
    @property
    def u0(self) -> float | None:
        return self.flow.u0

    @property
    def F(self) -> float | None:
        return self.flow.F

    @property
    def dx(self) -> float:
        return self.domain.dx

    @property
    def dy(self) -> float:
        return self.domain.dy

    @property
    def shape(self) -> tuple[int, int]:
        return self.domain.shape

    @property
    def t_end(self) -> float:
        return self.time.t_end

    @property
    def output_times(self) -> tuple[float, ...]:
        return self.output.output_times

    @property
    def time_scale(self) -> float | None:
        """h0 / u0 [s], the time unit of the scalings (5.1)."""
        return None if not self.flow.u0 else self.flow.h0 / self.flow.u0

    @property
    def reynolds(self) -> float | None:
        """Granular Reynolds number R = u0 sqrt(h0) / nu (5.7); inf when inviscid."""
        if self.flow.u0 is None:
            return None
        return (
            math.inf if not self.viscous else self.flow.u0 * math.sqrt(self.flow.h0) / self.flow.nu
        )

    @property
    def perturbation_wavenumbers(self) -> tuple[float, float]:
        """(kx, ky) of a uniform initial perturbation in SI units [1/m] (k_SI = k_hat / h0)."""
        if self.initial.kind != "uniform":
            return (0.0, 0.0)
        return (self.initial.k / self.flow.h0, self.initial.ky / self.flow.h0)

    # ---- serialisation -----------------------------------------------------------------------
    def to_dict(self, derived: bool = False) -> dict:
        return scene_to_dict(self, derived=derived)

    def to_toml(self) -> str:
        """The fully resolved scene as TOML; ``load_scene`` of it gives an equal Scene."""
        head = [f"# tiseg scene {self.name!r}, fully resolved (every default filled in)."]
        if self.source:
            head.append(f"# read from: {self.source}")
        d = []
        if self.flow.u0 is not None:
            d.append(f"u0 = {self.flow.u0:.6g} m/s, F = {self.flow.F:.6g}")
        d.append(
            f"dx = {self.dx:.6g} m, dy = {self.dy:.6g} m, grid {self.domain.nx} x {self.domain.ny}"
        )
        d.append(
            f"{len(self.output_times)} output times from {self.output_times[0]:g} to "
            f"{self.output_times[-1]:g} s"
        )
        head.append("# derived: " + "; ".join(d))
        return "\n".join(head) + "\n\n" + tomli_w.dumps(scene_to_dict(self))

    def with_overrides(self, overrides) -> "Scene":
        """A new, re-validated scene with ``section.key`` overrides applied."""
        data = scene_to_dict(self)
        apply_overrides(data, overrides)
        return build_labelled(data, self.name, self.source, f"{self.name!r}")

    @property
    def friction_constants(self) -> dict[str, float]:
        """{name: value} of every registered friction law's constants (the chosen law reads
        its own through ``FrictionParams``)."""
        sections = {"effects": self.effects, "material": self.material}
        return {
            c.name: getattr(sections[c.section], c.name)
            for law in LAWS.values()
            for c in law.constants
        }


def build_labelled(data: dict, name: str, source: str | None, label: str) -> Scene:
    try:
        return _build(data, name, source)
    except InputError as exc:
        raise InputError(f"scene {label}: {exc}") from None


def _build(data: dict, default_name: str, source: str | None) -> Scene:
    """Each section read and checked, in the order the cross-key rules need them."""
    keys = section_keys()
    top = Table(data, "", top_level_keys())
    if top.has("name"):
        name = check_name(top.string("name", default_name))
    else:
        name = safe_name(default_name)  # a file's stem: made safe, not refused
    description = top.string("description", "")

    def table(section: str) -> Table:
        return top.table(section, keys[section])

    material = read_material(table("material"))
    effects = read_effects(table("effects"))
    flow = read_flow(table("flow"), material, effects)

    ini_t = table("initial")
    kind = initial_kind(ini_t)

    time = TimeConfig(**read_section(TimeConfig, table("time")))
    domain, wavelengths = read_domain(table("domain"), ini_t, kind, flow)
    boundary = read_boundary(table("boundary"), domain)
    inflow = read_inflow(table("inflow"), top.has("inflow"), boundary, domain, flow)
    initial = read_initial(ini_t, kind, wavelengths, domain, boundary, flow, effects, material)
    h_scale = max(flow.h0, inflow.h if inflow is not None else 0.0)
    terrain = read_terrain(table("terrain"), domain, source, material.zeta, h_scale)
    if terrain.runout is not None and boundary.x_lo == "periodic":
        raise InputError(
            "terrain.runout: the bend joins two inclinations, which a periodic x boundary "
            "would wrap into each other; give boundary.x_lo and x_hi another kind"
        )
    initial = check_initial(initial, terrain, domain, source)
    numerics = read_numerics(table("numerics"), flow, domain.ny == 1, effects)
    output = read_output(table("output"), time.t_end, domain)
    _check_forcing_phase(inflow, time.t_end)
    return Scene(
        name=name,
        description=description,
        material=material,
        flow=flow,
        effects=effects,
        domain=domain,
        boundary=boundary,
        inflow=inflow,
        initial=initial,
        numerics=numerics,
        time=time,
        output=output,
        terrain=terrain,
        source=source,
    )


# the most periods of the inflow's forcing a run may span: past 2**40 the phase 2 pi f t has
# lost all but a few of its digits (and past about 1e307 Hz s it overflows)
MAX_FORCING_PERIODS = 2.0**40


def _check_forcing_phase(inflow, t_end: float) -> None:
    """Refuse a forcing frequency whose phase over the run cannot be represented: the
    modulation would be noise (or the run would stop in a math domain error)."""
    if inflow is None or not inflow.forcing_amplitude or not inflow.forcing_frequency:
        return
    f = inflow.forcing_frequency
    if not f * t_end <= MAX_FORCING_PERIODS:
        raise InputError(
            f"inflow.forcing_frequency={f!r}: {f * t_end:.3g} periods in time.t_end="
            f"{t_end:g} s, more than {MAX_FORCING_PERIODS:.3g}; the phase 2 pi f t cannot be "
            f"resolved (give at most {MAX_FORCING_PERIODS / t_end:.3g} Hz)"
        )
