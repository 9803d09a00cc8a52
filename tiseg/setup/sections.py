"""The sections of a scene, each key declared once: default, range or choices, doc, compiled.

Choices are read from the registries when a scene is read (``lambda: tuple(LAWS)``), so a
friction law, stepper or transport that user code registers is a valid choice. The constants of
the friction laws are declared by the laws themselves (`tiseg.model.physics.friction.Constant`)
and join the section they name (`law_constants`). What no single key can say (a key needed
only with another, a range that depends on another key) is checked after the generic read by
`tiseg.setup.validators`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..model.material import TABLE1
from ..solver.numerics.config import (
    FRICTION_SCHEMES,
    REGISTRIES,
    STEP_RULES,
    inflow_concentration,
    inflow_forcing,
)
from ..model.physics.friction import FRICTION_LAWS as LAWS
from ..model.physics.friction import ConstantsByName
from ..model.physics.sources import SOURCES, declared_constants
from .schema import constant_field, key, key_fields, key_names, key_of
from .initial import BUILTIN_KINDS, INITIAL_KINDS
from .table import MISSING
from .terrain_section import TerrainConfig

OUTPUT_PRECISIONS = ("f8", "f4")
PRECISIONS = ("f64", "f32")
RECONSTRUCTION_ALIASES = {"first_order": "first-order", "first": "first-order"}
PERTURBATION_MODES = ("eigen", "h", "phi", "noise", "h-noise")


# ---- the friction laws' constants ---------------------------------------------------------------
def law_constants(section: str) -> list:
    """The fields of the constants that the registered friction laws declare for ``section``
    (one per name, in registry order)."""
    seen: dict = {}
    for law in LAWS.values():
        for c in law.constants:
            if c.section == section and c.name not in seen:
                seen[c.name] = constant_field(c)
    return list(seen.values())


# ---- material (Table 1) -------------------------------------------------------------------------
_SMALL, _LARGE = TABLE1.small, TABLE1.large


@dataclass(frozen=True)
class SpeciesKeys:
    """The keys of ``material.small`` and ``material.large``; the defaults are Table 1's (those
    of `tiseg.model.material.Material`, different for each species)."""

    zeta1_deg: float = field(
        default=None, metadata=key("minimum angle of steady flow, mu1 = tan(zeta1)", units="degree")
    )
    zeta2_deg: float = field(
        default=None, metadata=key("maximum angle of steady flow, mu2 = tan(zeta2)", units="degree")
    )
    beta: float = field(
        default=None, metadata=key("dimensionless constant of (3.7)", positive=True, units="1")
    )
    L: float = field(default=None, metadata=key("length scale of (3.7) [m]", positive=True))
    zeta3_deg: float | None = field(
        default=None,
        metadata=key(
            "start angle of a thick layer at rest, mu3 = tan(zeta3), for effects.friction = "
            '"pouliquen-extended"; default zeta1_deg + 1 (a choice: Table 1 has no start '
            "angle, so measure zeta_start(h) and set it)",
            units="degree",
        ),
    )


def _species_doc(name: str) -> str:
    return f"table of the {name} grains' friction constants: " + "; ".join(
        f"``{f.name}``: {key_of(f).doc}" for f in key_fields(SpeciesKeys)
    )


@dataclass(frozen=True)
class MaterialKeys:
    """Table 1 of the paper; every constant can be overridden (``Material(zeta_deg=28)`` etc.).

    The section's values are a `tiseg.model.material.Material`; the keys of the friction laws'
    constants that live there (``beta_star``, ``kappa``) come from the laws."""

    zeta_deg: float = field(default=TABLE1.zeta_deg, metadata=key("slope angle zeta [degrees]"))
    alpha: float = field(
        default=TABLE1.alpha,
        metadata=key("basal slip parameter of the linear shear profile (2.12)", units="1"),
    )
    transport: str = field(
        default=TABLE1.transport,
        metadata=key(
            '"linear" (2.17) or "bagnold" (2.18)',
            choices=lambda: tuple(REGISTRIES["material.transport"]),
            compiled="operator",
        ),
    )
    g: float = field(
        default=TABLE1.g, metadata=key("gravitational acceleration [m/s^2]", positive=True)
    )
    chi: float = field(
        default=TABLE1.chi,
        metadata=key("shape factor; the model assumes chi = 1 (section 3)", units="1"),
    )
    small: SpeciesKeys = field(
        default=_SMALL, metadata=key(_species_doc("small"), table=SpeciesKeys)
    )
    large: SpeciesKeys = field(
        default=_LARGE, metadata=key(_species_doc("large"), table=SpeciesKeys)
    )


def material_fields() -> list:
    """The material section's key fields: its numbers, the laws' constants kept in the
    Material, then the species tables (the order of its allowed keys and of its TOML)."""
    own = key_fields(MaterialKeys)
    return (
        [f for f in own if not key_of(f).table]
        + law_constants("material")
        + [f for f in own if key_of(f).table]
    )


# ---- flow, effects ------------------------------------------------------------------------------
@dataclass(frozen=True)
class FlowConfig:
    """Reference steady uniform flow of section 4.

    ``u0`` and ``F`` are derived from (4.3), (4.9) when ``effects.friction`` is
    "pouliquen-mixture" (or "pouliquen-extended", in its dynamic regime F >= beta*) and a
    steady uniform flow exists; for the other friction laws ``u0`` may
    be given (``flow.u0``) and ``F`` follows from it, otherwise both are None. A scene without a
    steady flow (e.g. a release on a slope below zeta1^S or above zeta2^L, where material must
    stop or accelerate) is valid as long as nothing needs u0; ``no_steady`` then says why there
    is none, for the error of whatever does need it (an inflow without inflow.u, a uniform
    initial state).
    """

    h0: float = field(
        default=0.002,
        metadata=key("thickness of the reference steady uniform flow [m]", positive=True),
    )
    phi0: float = field(
        default=0.8,
        metadata=key("its small-particle concentration, in [0, 1]", lo=0.0, hi=1.0, units="1"),
    )
    nu: float = field(
        default=0.01,
        metadata=key("[m^(3/2)/s], coefficient of the viscous term of (6.2)", nonneg=True),
    )
    u0: float | None = field(
        default=None,
        metadata=key(
            "its speed [m/s]: derived from (4.3), (4.9) for the pouliquen-mixture friction, "
            "else give it",
            positive=True,
            # with a law of section 4's steady flow it is derived, not given
            write=lambda flow, scene: not LAWS[scene.effects.friction].steady,
        ),
    )
    F: float | None = None  # Froude number (4.3)
    no_steady: str | None = field(default=None, compare=False)


@dataclass(frozen=True)
class EffectsConfig(ConstantsByName):
    """Which physics is switched on; see the resolved properties on `Scene`.

    ``constants``: the values of the friction laws' constants that live in this section
    (``effects.coulomb_mu``), by name; each is also an attribute (``effects.coulomb_mu``)."""

    segregation: bool = field(
        default=True,
        metadata=key("large-particle transport (6.3); false: no phi field", compiled="operator"),
    )
    mobility_feedback: bool = field(
        default=True,
        metadata=key("friction (3.4) uses the local phi, else flow.phi0", compiled="operator"),
    )
    viscosity: bool = field(
        default=True, metadata=key("the nu h^(3/2) D term of (6.2)", compiled="operator")
    )
    friction: str = field(
        default="pouliquen-mixture",
        metadata=key(
            "the basal friction law (tiseg.model.physics.friction; a law registered there is a "
            "choice too)",
            choices=lambda: tuple(LAWS),
            compiled="operator",
        ),
    )
    sources: tuple[str, ...] = field(
        default=(),
        metadata=key(
            "source terms beyond (6.4), by name (tiseg.model.physics.sources; each brings its "
            "constants as keys of this section)",
            choices=lambda: tuple(SOURCES),
            compiled="operator",
        ),
    )
    constants: tuple[tuple[str, float], ...] = ()


def effects_fields() -> list:
    """The effects section's key fields: its switches, the laws' constants, then those of the
    registered source terms and the fields they read (keys only while a term that needs them
    is on, `tiseg.setup.validators.read_effects`)."""
    laws = law_constants("effects")
    known = {f.name for f in laws}
    comps = [constant_field(c) for n, c in declared_constants("effects").items() if n not in known]
    return key_fields(EffectsConfig) + laws + comps


# ---- domain, boundary ---------------------------------------------------------------------------
@dataclass(frozen=True)
class DomainConfig:
    """Rectangle x in [0, Lx] (downslope), y in [0, Ly] (cross-slope) of nx x ny cells."""

    Lx: float = field(metadata=key("downslope length [m]", positive=True, compiled="operator"))
    Ly: float = field(metadata=key("cross-slope width [m]", positive=True, compiled="operator"))
    resolution: float | None = field(
        default=None,
        metadata=key(
            "cells per metre, only used to derive nx, ny",
            positive=True,
            compiled="operator",
            units="m-1",
        ),
    )
    nx: int = field(
        kw_only=True,
        metadata=key("cells downslope (or give resolution)", lo=1, compiled="operator"),
    )
    ny: int = field(
        kw_only=True,
        metadata=key("cells across the slope; 1 = a 1D run", lo=1, compiled="operator"),
    )

    @property
    def dx(self) -> float:
        return self.Lx / self.nx

    @property
    def dy(self) -> float:
        return self.Ly / self.ny

    @property
    def is_1d(self) -> bool:
        return self.ny == 1

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx): the shape of one output field."""
        return (self.ny, self.nx)

    def cell_centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell-centre coordinates (x of length nx, y of length ny) [m]."""
        x = (np.arange(self.nx) + 0.5) * self.dx
        y = (np.arange(self.ny) + 0.5) * self.dy
        return x, y


def _side(default: str, doc: str):
    return field(
        default=default,
        metadata=key(doc, choices=lambda: tuple(REGISTRIES["boundary"]), compiled="operator"),
    )


@dataclass(frozen=True)
class BoundaryConfig:
    x_lo: str = _side("inflow", "upslope edge x = 0: inflow (6.8) needs an [inflow] table")
    x_hi: str = _side("outflow", "downslope edge x = Lx")
    y_lo: str = _side("periodic", "cross-slope edge y = 0")
    y_hi: str = _side("periodic", "cross-slope edge y = Ly (periodic needs both sides periodic)")

    def as_tuple(self) -> tuple[str, str, str, str]:
        """(x_lo, x_hi, y_lo, y_hi), the order of ``OperatorConfig.bc``."""
        return (self.x_lo, self.x_hi, self.y_lo, self.y_hi)


# ---- inflow -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class InflowConfig:
    """Inflow at x = 0, (6.8)-(6.9):

    h(0, y, t) = (1 - exp(-ramp_rate t)) (1 + forcing_amplitude sin(2 pi forcing_frequency t)) h,
    u = u,  v = 0,
    phi(0, y, t) = phi + perturbation sin(2 pi modes y / Ly) + noise phi r(y),

    switched off (h = 0) for t > stop_time when a finite release is modelled. The forcing
    (default off) modulates the inflow thickness, and with it the mass flux h u, periodically
    in time: the controlled inlet perturbation with which roll waves are excited at a chosen
    frequency (Forterre & Pouliquen 2003). It enters only the host-side inflow thickness of
    each stage (a run-time number of the kernels), so it costs nothing when zero and can be
    changed with ``Simulation.set_parameters``. In a 1D run the
    single cell row has its centre at y = Ly/2, where the perturbation sin(pi modes) vanishes.

    ``noise`` (default 0) adds a random cross-slope profile r(y) of unit RMS, band-limited to
    wavelengths of 2 cm and more and the same on every grid
    (`tiseg.solver.numerics.config.inflow_noise`), drawn from ``seed``: without it the
    symmetry of (6.9) is broken by round-off alone, so the finger pattern of one run is one
    draw that changes with any change of the numerics; with it, runs that differ only in
    ``seed`` are physically different realisations (ensembles, ``tiseg sweep``).

    ``width`` and ``y0`` (default: the whole width) make the inlet a gate of that width centred
    at y = y0, as in the self-channelised flows of Rocha, Johnson & Gray (2019): the inflow state
    above enters through the cells of the gate, and the rest of the upslope edge is a wall.
    """

    h: float = field(metadata=key("inflow thickness [m] (default flow.h0)", positive=True))
    u: float = field(metadata=key("inflow speed [m/s] (default flow.u0)", positive=True))
    phi: float = field(
        metadata=key("inflow concentration of (6.9) (default flow.phi0)", lo=0.0, hi=1.0, units="1")
    )
    ramp_rate: float = field(default=10.0, metadata=key("[1/s]; 0 = sudden inflow", nonneg=True))
    perturbation: float = field(default=8e-5, metadata=key("delta of (6.9)", units="1"))
    modes: int = field(default=1, metadata=key("number of sine periods across Ly", lo=1))
    stop_time: float | None = field(
        default=None,
        metadata=key("[s]; None = continuous inflow", positive=True, allow_inf=True),
    )
    noise: float = field(
        default=0.0,
        metadata=key("relative RMS amplitude of the random profile", nonneg=True, units="1"),
    )
    seed: int = field(default=0, metadata=key("realisation of the random profile", lo=0))
    forcing_frequency: float = field(
        default=0.0,
        metadata=key(
            "[Hz] of the periodic modulation of the inflow thickness (and flux); 0 = none",
            nonneg=True,
        ),
    )
    forcing_amplitude: float = field(
        default=0.0,
        metadata=key(
            "relative amplitude of that modulation, in [0, 1): h (1 + a sin(2 pi f t))",
            lo=0.0,
            hi=1.0,
            units="1",
        ),
    )

    width: float | None = field(
        default=None,
        metadata=key(
            "[m] of a localised inlet centred at y0; None = the whole width",
            positive=True,
            compiled="operator",
        ),
    )
    y0: float | None = field(
        default=None,
        metadata=key(
            "[m] cross-slope centre of the inlet (default Ly/2)", nonneg=True, compiled="operator"
        ),
    )

    def rows(self, ny: int, dy: float) -> tuple[int, int] | None:
        """Interior cell rows [lo, hi) of the inlet: the cells between the cell faces nearest
        y0 -+ width/2; None for the full-width inflow (no width given)."""
        if self.width is None:
            return None
        y0 = ny * dy / 2 if self.y0 is None else self.y0
        lo = max(0, round((y0 - self.width / 2) / dy))
        hi = min(ny, round((y0 + self.width / 2) / dy))
        return (lo, hi)

    def thickness(self, t: float) -> float:
        """Inflow thickness at time t, (6.8a) times the forcing; 0 after ``stop_time``."""
        if self.stop_time is not None and t > self.stop_time:
            return 0.0
        ramp = 1.0 if self.ramp_rate <= 0 else -math.expm1(-self.ramp_rate * t)
        return ramp * self.h * inflow_forcing(t, self.forcing_frequency, self.forcing_amplitude)

    def concentration(self, y, Ly: float):
        """Inflow concentration (6.8d), (6.9) plus the noise at cross-slope positions y [m]."""
        return inflow_concentration(
            y, Ly, self.phi, self.perturbation, self.modes, self.noise, self.seed
        )


# ---- initial state ------------------------------------------------------------------------------
def _ini(doc: str, kinds: tuple[str, ...], read=MISSING, **meta):
    """An initial-state key: None unless its kind is chosen; ``read``: the default that kind
    reads (a value, a callable of the scene read so far, or MISSING: required)."""
    return field(default=None, metadata=key(doc, kinds=kinds, read_default=read, **meta))


def _h0(ctx):
    return ctx.flow.h0


def _phi0(ctx):
    return ctx.flow.phi0


_UNIFORM = ("uniform",)


@dataclass(frozen=True)
class InitialConfig:
    """Initial state; only the fields of ``kind`` are set, the others are None.

    * empty: the empty slope (6.7).
    * uniform: the steady uniform state (h0, u0, phi0) plus a perturbation of relative
      ``amplitude`` with dimensionless wavenumbers ``k`` (downslope) and ``ky`` (cross-slope) in
      the scalings (5.1), i.e. k_SI = k / h0; ``mode`` "eigen" is the most unstable linear mode
      (computed by the simulation), "h"/"phi" perturb one field, "noise" is random in phi,
      "h-noise" a random downslope profile of h (``seed``; `tiseg.setup.initial.thickness_noise`).
      ``wavelengths`` = Lx k_SI / (2 pi), the number of downslope wavelengths in the domain.
    * dam-break: h = h_left for x < x0, h_right beyond, at rest, concentration ``phi``.
    * release: a block [x0, x1] x [y0, y1] of thickness h and concentration phi, at rest.
    * channel: a layer of thickness h at rest, with one straight downslope channel of
      concentration ``phi_channel`` and ``width`` centred at y = Ly/2 between levees of
      ``phi_levee`` (the verification case of sharp contacts, `tiseg.post.problems.steady_channel`).
    * layer: a uniform static layer of thickness ``layer_h`` and concentration ``phi`` at rest
      on the whole slope, the erodible bed of erosion-deposition waves (Edwards & Gray 2015);
      under the extended friction law it is held at rest for h_stop < layer_h < h_start.
    * cap: a parabolic cap h = h (1 - ((x - x0) / half_width)^2) sliding downslope at ``u``,
      uniform across the slope, concentration ``phi``: the start of the similarity solution
      of Savage & Hutter (1991) (`tiseg.model.exact_friction.ParabolicCap`).
    * lake: material at rest whose free surface lies at ``level`` above the reference plane:
      h = max(level - b, 0) over the bed b of ``[terrain]`` (normal to the plane), concentration
      ``phi``.
    * file: the thickness read from the raster ``path`` (its coordinates shifted by
      ``origin_x``, ``origin_y``), at rest, concentration ``phi``.

    Solid cells of ``[terrain]`` hold no material whatever the kind (h = 0 there).

    The fields are in the order each kind lists its keys; ``kinds`` says which kinds use a key.
    """

    kind: str = field(
        default="empty",
        metadata=key(
            "which initial state (the list above, or one registered by "
            "tiseg.setup.initial.register_initial)",
            choices=lambda: tuple(INITIAL_KINDS),
            kinds=BUILTIN_KINDS,
        ),
    )
    amplitude: float | None = _ini(
        "uniform: relative perturbation amplitude, < 1", _UNIFORM, 0.0, lo=0.0, units="1"
    )
    k: float | None = _ini(
        "uniform: downslope wavenumber in the scalings (5.1)", _UNIFORM, 0.0, nonneg=True
    )
    ky: float | None = _ini(
        "uniform: cross-slope wavenumber, (5.1) scalings", _UNIFORM, 0.0, nonneg=True
    )
    mode: str | None = _ini(
        "uniform: eigen (most unstable mode), h, phi, noise (in phi) or h-noise",
        _UNIFORM,
        "eigen",
        choices=PERTURBATION_MODES,
    )
    seed: int | None = _ini(
        'uniform: random seed of mode = "noise" or "h-noise"', _UNIFORM, 0, lo=0
    )
    wavelengths: float | None = _ini(
        "uniform: downslope wavelengths in Lx (sets Lx)", _UNIFORM, None, positive=True
    )
    # a release block starts at x0 >= 0, a dam lies inside (0, Lx): validators.read_initial
    x0: float | None = _ini(
        "dam-break: dam position; release: block start; cap: centre [m]",
        ("dam-break", "release", "cap"),
    )
    h_left: float | None = _ini(
        "dam-break: thickness upslope of x0 [m]", ("dam-break",), _h0, nonneg=True
    )
    h_right: float | None = _ini(
        "dam-break: thickness downslope of x0 [m]", ("dam-break",), 0.0, nonneg=True
    )
    x1: float | None = _ini("release: block end [m]", ("release",))
    y0: float | None = _ini("release: block start across the slope [m]", ("release",), 0.0, lo=0.0)
    y1: float | None = _ini(
        "release: block end across the slope [m]", ("release",), lambda ctx: ctx.domain.Ly
    )
    width: float | None = _ini(
        "channel: width of the channel at y = Ly/2 [m]", ("channel",), positive=True
    )
    phi_channel: float | None = _ini(
        "channel: concentration in the channel (default 1)",
        ("channel",),
        1.0,
        lo=0.0,
        hi=1.0,
        units="1",
    )
    phi_levee: float | None = _ini(
        "channel: concentration in the levees (default 0)",
        ("channel",),
        0.0,
        lo=0.0,
        hi=1.0,
        units="1",
    )
    h: float | None = _ini(
        "release, channel: thickness; cap: thickness at the centre [m] (default flow.h0)",
        ("release", "channel", "cap"),
        _h0,
        positive=True,
    )
    half_width: float | None = _ini(
        "cap: half the cap's downslope length [m]", ("cap",), positive=True
    )
    u: float | None = _ini("cap: downslope speed at the start [m/s]", ("cap",), 0.0, nonneg=True)
    layer_h: float | None = _ini(
        "layer: thickness of the static layer [m]", ("layer",), positive=True
    )
    level: float | None = _ini(
        "lake: height of the free surface above the reference plane, normal to it; h = "
        "max(level - b, 0) at rest [m]",
        ("lake",),
    )
    path: str | None = _ini(
        "file: raster of the initial thickness normal to the plane [m] (.asc, .nc with a "
        "variable b, GeoTIFF), resampled onto the cells, nodata = 0; a relative path is "
        "taken from the scene file's folder",
        ("file",),
    )
    origin_x: float | None = _ini(
        "file: the raster's x coordinates are shifted by this on the domain [m]", ("file",), 0.0
    )
    origin_y: float | None = _ini(
        "file: the raster's y coordinates are shifted by this on the domain [m]", ("file",), 0.0
    )
    phi: float | None = _ini(
        "dam-break, release, layer, cap, lake, file: concentration (default flow.phi0)",
        ("dam-break", "release", "layer", "cap", "lake", "file"),
        _phi0,
        lo=0.0,
        hi=1.0,
        units="1",
    )


def initial_keys() -> dict[str, tuple[str, ...]]:
    """{initial.kind: the keys it accepts}: a key of another kind is an error (it would
    otherwise be unused). The built-in kinds' keys are declared on the fields above (``kinds``);
    a registered kind lists its own (`tiseg.setup.initial.InitialKind.keys`)."""
    fs = key_fields(InitialConfig)
    return {
        kind: tuple(f.name for f in fs if kind in key_of(f).kinds or f.name in ("kind", *spec.keys))
        for kind, spec in INITIAL_KINDS.items()
    }


# ---- numerics -----------------------------------------------------------------------------------
@dataclass(frozen=True)
class NumericsConfig:
    reconstruction: str = field(
        default="weno",
        metadata=key(
            '"weno" (a WENO-type slope; docs/numerics.md says how it differs from Noelle '
            '2000\'s), "minmod", "first-order"',
            choices=lambda: tuple(REGISTRIES["numerics.reconstruction"]),
            order=("weno", "minmod", "first-order"),  # the most accurate first
            aliases=RECONSTRUCTION_ALIASES,
            compiled="operator",
        ),
    )
    theta: float = field(
        default=1.5,
        metadata=key("generalised minmod parameter, in [1, 2]", lo=1.0, hi=2.0, units="1"),
    )
    flux: str = field(
        default="kt",
        metadata=key(
            '"kt" (Kurganov-Tadmor 2000, as in section 6.2), "central-upwind" (Kurganov, '
            'Noelle & Petrova 2001) or "rusanov" (local Lax-Friedrichs: on these edge states '
            'the same as "kt")',
            choices=lambda: tuple(REGISTRIES["numerics.flux"]),
            compiled="operator",
        ),
    )
    phi_flux: str = field(
        default="upwind",
        metadata=key(
            "h phi flux: the mass flux times the upwind phi - G(phi) "
            '("upwind", keeps contacts sharp), or the flux scheme\'s own ("central", the '
            "paper's)",
            choices=lambda: tuple(REGISTRIES["numerics.phi_flux"]),
            compiled="operator",
        ),
    )
    stepper: str = field(
        default="rkc",
        metadata=key(
            'Runge-Kutta-Chebyshev as in section 6.2, or SSP RK / Euler, or "hancock": '
            "dimensionally split MUSCL-Hancock sweeps (projected friction; the viscosity as "
            "a sub-step of RKC stages)",
            choices=lambda: tuple(REGISTRIES["numerics.stepper"]),
            compiled="simulation",
        ),
    )
    # its default depends on stepper and step_rule: validators.numerics_defaults
    cfl: float = field(
        default=None,
        metadata=key(
            'Courant number of the hyperbolic part, in [0.001, 1]; 0.25 with step_rule "max", '
            '0.5 with "sum" and "local" (each rule\'s forward-Euler positivity bound), 0.6 '
            'with stepper "hancock" (each sweep is stable up to 1; h >= 0 whatever the step)',
            positive=True,
            hi=1.0,
            units="1",
        ),
    )
    step_rule: str = field(
        default="max",
        metadata=key(
            '"max": dt = cfl min(dx/a, dy/b); "sum": dt = cfl / (a/dx + b/dy); "local": dt = '
            "cfl / max over cells of (a/dx + b/dy), a and b from the cell's faces (Kurganov & "
            "Petrova 2007; up to 2x longer steps where one direction dominates)",
            choices=lambda: tuple(STEP_RULES),
            compiled="operator",
        ),
    )
    precision: str = field(
        default="f64",
        metadata=key(
            "floating-point precision of the kernels", choices=PRECISIONS, compiled="simulation"
        ),
    )
    h_min: float = field(
        default=1e-4,
        metadata=key("fluxes vanish where h < h_min (section 6.2) [m]", positive=True),
    )
    h_eps: float = field(
        default=1e-7,
        metadata=key(
            "desingularisation thickness for u = hu / h [m], >= 1e-9, < h_min", positive=True
        ),
    )
    u_eps: float = field(
        default=1e-3,
        metadata=key(
            'regularises the friction direction u / |u| [m/s] ("regularised")', positive=True
        ),
    )
    friction_scheme: str = field(
        default="projected",
        metadata=key(
            "basal friction as a projection: after each stage a cell's momentum shrinks by "
            "the friction impulse and stops exactly where the impulse can cancel it (Mangeney "
            'et al. 2007), so material comes to rest and stays there; or "regularised": an '
            "explicit source with u / max(|u|, u_eps) (section 6.2), under which material that "
            "friction should hold creeps at up to u_eps (SSP steppers only)",
            choices=lambda: FRICTION_SCHEMES,
            compiled="operator",
        ),
    )
    max_stages: int = field(
        default=200,
        metadata=key("upper bound on the number of RKC stages", lo=2, compiled="simulation"),
    )


# ---- time, output -------------------------------------------------------------------------------
@dataclass(frozen=True)
class TimeConfig:
    t_end: float = field(metadata=key("end time of the run [s]", positive=True))


@dataclass(frozen=True)
class GaugeKeys:
    """One gauge of ``[[output.gauges]]``: h, u, v and phi at a point after every step
    (`tiseg.run.gauges`)."""

    x: float = field(metadata=key("downslope position, in [0, Lx] [m]"))
    y: float | None = field(
        default=None, metadata=key("cross-slope position, in [0, Ly]; default Ly/2 [m]")
    )
    name: str | None = field(
        default=None,
        metadata=key(
            "its name in gauges.csv's columns (letters, digits, _ - .); default g1, g2, ... "
            "in the order given"
        ),
    )


@dataclass(frozen=True)
class OutputConfig:
    """Snapshot times. ``output_times`` is the resolved, sorted union of ``times``, the multiples
    of ``interval`` up to t_end, t = 0 and t_end."""

    interval: float | None = field(
        default=None,
        metadata=key("a snapshot every interval seconds, >= t_end / 1e6 [s]", positive=True),
    )
    times: tuple[float, ...] = field(default=(), metadata=key("snapshots at these times too [s]"))
    checkpoint_interval: float | None = field(
        default=None,
        metadata=key("simulated seconds between checkpoints, >= t_end / 1e6 [s]", positive=True),
    )
    output_times: tuple[float, ...] = ()
    precision: str | None = field(
        default=None,
        metadata=key(
            'fields.nc data type: "f8", "f4"; None: the run\'s precision',
            choices=OUTPUT_PRECISIONS,
            aliases={"f64": "f8", "f32": "f4"},
        ),
    )
    significant_digits: int | None = field(
        default=None,
        metadata=key("quantise fields.nc to this many decimal digits", lo=1),
    )
    peak_fields: bool = field(
        default=True,
        metadata=key(
            "h_max, speed_max, arrival_time and the deposit in fields.nc, exact per step "
            "(tiseg.run.peaks); false: no peak fields, no work for them",
            compiled="simulation",
        ),
    )
    gauges: tuple[GaugeKeys, ...] = field(
        default=(),
        metadata=key(
            "points [[output.gauges]] with x, y and a name: h, u, v, phi there after every "
            "step, interpolated bilinearly between cell centres, in gauges.csv "
            "(tiseg.run.gauges)",
            table=GaugeKeys,
            many=True,
            compiled="simulation",
        ),
    )

    def dtype(self, run_precision: str) -> str:
        """NetCDF type of the stored fields for a run in ``run_precision`` ("f64"/"f32")."""
        if self.precision is not None:
            return self.precision
        return "f8" if run_precision == "f64" else "f4"


# ---- the sections and their keys ----------------------------------------------------------------
# the dataclass that declares each section's keys (material: its Material is built from them)
SECTIONS = {
    "material": MaterialKeys,
    "flow": FlowConfig,
    "effects": EffectsConfig,
    "domain": DomainConfig,
    "boundary": BoundaryConfig,
    "inflow": InflowConfig,
    "initial": InitialConfig,
    "terrain": TerrainConfig,
    "numerics": NumericsConfig,
    "time": TimeConfig,
    "output": OutputConfig,
}


def section_fields(section: str) -> list:
    """The key fields of a section now (with the registered laws' constants)."""
    if section == "material":
        return material_fields()
    if section == "effects":
        return effects_fields()
    if section == "initial":
        # the keys of every kind, kind by kind (the order of the allowed-key lists)
        by_name = {f.name: f for f in key_fields(InitialConfig)}
        names = dict.fromkeys(k for keys in initial_keys().values() for k in keys)
        return [by_name[n] for n in names]
    return key_fields(SECTIONS[section])


def section_keys() -> dict[str, tuple[str, ...]]:
    """{section: its allowed keys}, derived from the declarations (and the registry now)."""
    return {s: tuple(f.name for f in section_fields(s)) for s in SECTIONS}


def top_level_keys() -> tuple[str, ...]:
    return ("name", "description") + tuple(SECTIONS)


SPECIES_KEYS = key_names(SpeciesKeys)


def key_units(dotted: str) -> str | None:
    """The unit (UDUNITS form, `tiseg.setup.schema.units_of`) of the number key ``dotted``
    ("flow.nu", "material.small.beta"), or None when it declares none or is not a key."""
    from .schema import units_of

    parts = dotted.split(".")
    if len(parts) == 3 and parts[0] == "material" and parts[1] in ("small", "large"):
        fields = key_fields(SpeciesKeys)
    elif len(parts) == 2 and parts[0] in SECTIONS:
        fields = section_fields(parts[0])
    else:
        return None
    f = next((f for f in fields if f.name == parts[-1]), None)
    return units_of(f) if f is not None else None
