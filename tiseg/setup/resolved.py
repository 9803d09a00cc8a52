"""The resolved scene: every section validated, every default filled in, one frozen value.

Build it with `tiseg.scene.load_scene`; its properties are the switches and numbers the
run derives from the sections (``viscous``, ``feedback``, ``dx``, the Reynolds number (5.7)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import tomli_w

from ..material import Material
from ..physics.friction import FRICTION_LAWS as LAWS
from .overrides import apply_overrides
from .sections import (
    BoundaryConfig,
    DomainConfig,
    EffectsConfig,
    FlowConfig,
    InflowConfig,
    InitialConfig,
    NumericsConfig,
    OutputConfig,
    TimeConfig,
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
        # reading builds Scenes, so it is imported when first needed, not at the top
        from .reading import build_labelled

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
