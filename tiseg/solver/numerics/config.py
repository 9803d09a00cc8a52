"""Everything the semi-discrete operator needs, as plain numbers and switches.

`OperatorConfig` is shared by the Taichi operator (`tiseg.solver.numerics.operator`) and the
NumPy reference (`tiseg.solver.reference.operator`) so both see exactly the same problem. Switches
(``segregation``, ``viscous``, ``feedback``, ``friction``, ``reconstruction``, ``flux``,
``phi_flux``, 1D/2D, boundaries)
are compile-time choices of the Taichi kernels; numbers (slope, nu, inflow state, ...) are
run-time parameters.

The array layout (`Layout`) is the same for both: cell-centred conserved variables
``q = (h, hu[, hv][, h*phi])`` with ``G = 2`` ghost cells on each side in x, and in y unless the
run is 1D (``ny == 1``: one row, no ghosts, no v component, no cross-slope work).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from ...errors import InputError
from ...model.bed_line import BedLine
from ...model.physics.friction import FRICTION_LAWS as _LAWS
from ...model.physics.friction import FrictionParams  # the laws own it; imported from here before
from ...model.physics.segregation import TRANSPORTS as _TRANSPORTS
from ...model.physics.sources import MAX_STENCIL, SOURCES, components
from ..timestepping import STEPPERS as _STEPPERS
from .boundaries import BOUNDARIES as _BOUNDARIES
from .fluxes import FLUXES as _FLUXES
from .fluxes import PHI_FLUXES as _PHI_FLUXES
from .reconstruction import RECONSTRUCTIONS as _RECONSTRUCTIONS

# The registries behind the scene's choices are read when asked, never frozen: a friction law,
# transport, slope, flux, boundary or stepper that user code registers after import is a valid
# choice everywhere. `REGISTRIES` names each by the scene key it serves; the module attributes
# of before (``FRICTION_LAWS``, ``FLUXES``, ..., ``SPLIT_STEPPERS``) give their keys now.
REGISTRIES = {
    "effects.friction": _LAWS,  # tiseg.model.physics.friction
    "material.transport": _TRANSPORTS,  # G(phi), tiseg.model.physics.segregation
    "numerics.reconstruction": _RECONSTRUCTIONS,  # the slopes (.reconstruction)
    "numerics.flux": _FLUXES,  # face flux of the whole system (.fluxes)
    "numerics.phi_flux": _PHI_FLUXES,  # the h phi component of that flux (.fluxes)
    "boundary": _BOUNDARIES,  # boundary.*: the conditions (.boundaries)
    "numerics.stepper": _STEPPERS,  # tiseg.solver.timestepping
    "effects.sources": SOURCES,  # terms beyond (6.4), tiseg.model.physics.sources
}
# the names of before, each now the keys of its registry as they stand (`registered`)
CHOICE_NAMES = {
    "FRICTION_LAWS": "effects.friction",
    "TRANSPORTS": "material.transport",
    "RECONSTRUCTIONS": "numerics.reconstruction",
    "FLUXES": "numerics.flux",
    "PHI_FLUXES": "numerics.phi_flux",
    "BOUNDARIES": "boundary",
    "BOUNDARY_KINDS": "boundary",
    "STEPPERS": "numerics.stepper",
}


def registered(name: str) -> tuple[str, ...]:
    """The registered choices that the old module attribute ``name`` stood for, read now."""
    return tuple(REGISTRIES[CHOICE_NAMES[name]])


def __getattr__(name: str):
    if name in CHOICE_NAMES:
        return registered(name)
    if name == "SPLIT_STEPPERS":
        return tuple(n for n in _STEPPERS if is_split(n))
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def is_split(stepper: str) -> bool:
    """Whether the registered stepper ``stepper`` advances by dimensionally split sweeps
    (tiseg.solver.numerics.split)."""
    return bool(getattr(_STEPPERS.get(stepper), "split", False))


def check_choice(key: str, value, allowed) -> None:
    """An InputError naming ``key``, ``value`` and the allowed values, unless ``value`` is one of
    ``allowed`` (a registry or a tuple, read now)."""
    if value not in allowed:
        raise InputError(f"{key}={value!r}: choose one of {', '.join(map(str, allowed))}")


# numerics.friction_scheme: basal friction as an explicit source regularised by u_eps, or as a
# projection after each stage that stops cells exactly (tiseg.model.physics.pointwise)
FRICTION_SCHEMES = ("regularised", "projected")
# numerics.step_rule -> the Courant number at the forward-Euler positivity bound of that rule
STEP_RULES = {"max": 0.25, "sum": 0.5, "local": 0.5}
# the default Courant number per sweep: stable up to 1, and 0.6 did the least work for a
# given error on the Stoker dam break (benchmarks/README.md section 7; the error of a fan
# grows with cfl, a smooth wave's much less)
SPLIT_CFL = 0.6
# codes of the conditions (kept for callers that used them; the kernels take the components)
INFLOW, OUTFLOW, PERIODIC, WALL = range(4)
BC_CODES = {"inflow": INFLOW, "outflow": OUTFLOW, "periodic": PERIODIC, "wall": WALL}
GHOST = 2
SIDES = ("x_lo", "x_hi", "y_lo", "y_hi")  # the boundary.* keys, in the order of bc
# the scene keys of the grid, of the terrain
_TERRAIN = ("terrain.shapes", "terrain.bed", "terrain.origin_x", "terrain.origin_y")
_GRID = ("domain.Lx", "domain.Ly", "domain.resolution", "domain.nx", "domain.ny")
NOISE_MIN_WAVELENGTH = 0.02  # [m] shortest cross-slope wavelength of the inflow noise


def inflow_noise(y, Ly: float, seed: int) -> np.ndarray:
    """Unit-RMS random cross-slope profile r(y) of the inflow noise (``inflow.noise``).

    r(y) = sqrt(2 / N) sum_{n=1..N} cos(2 pi n y / Ly + theta_n), with N = floor(Ly / 2 cm)
    (at least 1) and phases theta_n drawn uniformly from numpy's PCG64 generator seeded with
    ``seed``. Periodic across Ly, band-limited, of mean 0 and RMS 1 over [0, Ly], and the same
    function of y on every grid: a seed names one physical realisation, so a grid study with
    seeds compares the same perturbations at every resolution. Its values never exceed
    sqrt(2 N) in magnitude. Why a spectrum rather than a value per cell: white noise per cell
    would put less and less of its variance into the resolved, physically unstable
    wavelengths (~5 cm) as the grid is refined.
    """
    y = np.asarray(y, dtype=float)
    n_modes = noise_modes(Ly)
    theta = np.random.default_rng(int(seed)).uniform(0.0, 2.0 * np.pi, n_modes)
    n = np.arange(1, n_modes + 1)
    arg = 2.0 * np.pi * np.multiply.outer(y, n) / Ly + theta
    return math.sqrt(2.0 / n_modes) * np.cos(arg).sum(axis=-1)


def noise_modes(Ly: float) -> int:
    """Number N of Fourier modes of `inflow_noise` across Ly."""
    return max(1, int(math.floor(Ly / NOISE_MIN_WAVELENGTH + 1e-9)))


def inflow_forcing(t: float, frequency: float, amplitude: float) -> float:
    """The factor 1 + amplitude sin(2 pi frequency t) of the forced inflow thickness
    (``inflow.forcing_frequency`` [Hz], ``inflow.forcing_amplitude``); exactly 1 without
    forcing, so an unforced inflow is the same number to the last bit."""
    if amplitude == 0.0 or frequency == 0.0:
        return 1.0
    return 1.0 + amplitude * math.sin(2.0 * math.pi * frequency * t)


def inflow_concentration(
    y, Ly: float, phi: float, delta: float, modes: int, noise: float = 0.0, seed: int = 0
) -> np.ndarray:
    """Inflow concentration at cross-slope positions y [m]: (6.9) plus the optional noise,

    phi(0, y) = phi + delta sin(2 pi modes y / Ly) + noise phi r(y)   (r: `inflow_noise`),

    clipped to [0, 1] (the scene keeps it inside; the clip only guards round-off). The one
    definition used by the Taichi operator (as a field filled once), the NumPy reference and
    the scene."""
    y = np.asarray(y, dtype=float)
    k = 2.0 * math.pi * modes / Ly  # k y in this order, as the kernels once had it: the f64
    out = phi + delta * np.sin(k * y)  # profile is bitwise the one computed there before
    if noise:
        out = out + noise * phi * inflow_noise(y, Ly, seed)
    return np.clip(out, 0.0, 1.0)


@dataclass(frozen=True)
class Layout:
    """Array layout: component indices and index ranges of interior cells."""

    nx: int
    ny: int
    segregation: bool

    @property
    def is_1d(self) -> bool:
        return self.ny == 1

    @property
    def gx(self) -> int:
        return GHOST

    @property
    def gy(self) -> int:
        return 0 if self.is_1d else GHOST

    @property
    def NX(self) -> int:
        return self.nx + 2 * self.gx

    @property
    def NY(self) -> int:
        return self.ny + 2 * self.gy

    # component indices of q (and of the primitive vector w = (h, u[, v][, phi]))
    @property
    def H(self) -> int:
        return 0

    @property
    def HU(self) -> int:
        return 1

    @property
    def HV(self) -> int:
        return -1 if self.is_1d else 2

    @property
    def HPHI(self) -> int:
        return (2 if self.is_1d else 3) if self.segregation else -1

    @property
    def nc(self) -> int:
        return 2 + (0 if self.is_1d else 1) + (1 if self.segregation else 0)

    def interior(self):
        """Slices of the interior cells in an (NX, NY) array."""
        return (slice(self.gx, self.gx + self.nx), slice(self.gy, self.gy + self.ny))


def from_keys(*keys: str, what: str | None = None) -> dict:
    """Field metadata: the scene keys a field of `OperatorConfig` is made from. Whether the
    kernels are compiled for the field is the schema's word on those keys (``compiled =
    "operator"``, `tiseg.setup.schema.compiled_keys`): `compiled_fields` reads it. ``what``
    names the change in the message of a refused one (``Simulation.set_parameters``); the keys
    themselves by default."""
    return {"keys": keys, "what": what or ", ".join(keys)}


@dataclass(frozen=True)
class OperatorConfig:
    """The operator's problem. The numerics' choices and numbers have no defaults here: the
    scene declares them once (`tiseg.setup.sections.NumericsConfig`), and a test that
    builds a config by hand states the ones it means."""

    layout: Layout = field(
        metadata=from_keys(*_GRID, "effects.segregation", what="the grid or the segregation switch")
    )
    dx: float = field(metadata=from_keys(*_GRID, what="the grid"))
    dy: float = field(metadata=from_keys(*_GRID, what="the grid"))
    Ly: float = field(metadata=from_keys("domain.Ly", what="the domain"))
    # physics switches
    viscous: bool = field(default=False, metadata=from_keys("effects.viscosity"))
    # friction depends on the local phi
    feedback: bool = field(default=False, metadata=from_keys("effects.mobility_feedback"))
    friction: str = field(default="pouliquen-mixture", metadata=from_keys("effects.friction"))
    # physics numbers
    g: float = 9.81
    zeta: float = math.radians(27.0)
    # G(phi): "linear" (2.17) or "bagnold" (2.18)
    transport: str = field(default="linear", metadata=from_keys("material.transport"))
    alpha: float = 1.0 / 7.0  # G(phi) = (1 - alpha) phi (1 - phi), (2.17)
    nu: float = 0.0
    phi_ref: float = 0.8  # concentration used by the friction when feedback is off
    fric: FrictionParams | None = None
    # numerics: the scene's numerics.* keys of the same names
    reconstruction: str = field(kw_only=True, metadata=from_keys("numerics.reconstruction"))
    theta: float = field(kw_only=True)
    flux: str = field(kw_only=True, metadata=from_keys("numerics.flux"))
    phi_flux: str = field(kw_only=True, metadata=from_keys("numerics.phi_flux"))
    weno_eps: float = 1e-6
    h_ref: float = 2e-3  # scales making the WENO smoothness indicators dimensionless
    u_ref: float = 0.2
    h_min: float = field(kw_only=True)
    h_eps: float = field(kw_only=True)
    u_eps: float = field(kw_only=True)
    friction_scheme: str = field(kw_only=True, metadata=from_keys("numerics.friction_scheme"))
    # the stability pass also finds the largest per-cell rate of step_rule "local"
    local_step_rate: bool = field(
        default=False,
        metadata=from_keys("numerics.step_rule", what='numerics.step_rule (to or from "local")'),
    )
    # the dimensionally split scheme (numerics.stepper "hancock", tiseg.solver.numerics.split):
    # friction only as the projection; a viscosity is its own sub-step
    split: bool = False
    # boundaries: x_lo, x_hi, y_lo, y_hi
    bc: tuple = field(
        default=("outflow", "outflow", "periodic", "periodic"),
        metadata=from_keys(*(f"boundary.{s}" for s in SIDES), what="the boundaries"),
    )
    # inflow (6.8)-(6.9)
    inflow_h: float = 0.0
    inflow_u: float = 0.0
    inflow_phi: float = 0.0
    inflow_ramp: float = 10.0
    inflow_delta: float = 0.0
    inflow_modes: int = 1
    inflow_noise: float = 0.0  # relative amplitude of the random profile (inflow.noise)
    inflow_seed: int = 0
    inflow_stop: float = math.inf
    inflow_forcing_frequency: float = 0.0  # [Hz] (inflow.forcing_frequency)
    inflow_forcing_amplitude: float = 0.0  # relative (inflow.forcing_amplitude)
    # the inlet's interior rows [lo, hi) (inflow.width, inflow.y0); None = every row
    inflow_rows: tuple | None = field(
        default=None,
        metadata=from_keys("inflow.width", "inflow.y0", what="inflow.width and inflow.y0"),
    )
    # source terms beyond (6.4) and the auxiliary fields they read (tiseg.model.physics.sources),
    # composed into the kernels; their constants, and those of the fields, by name: run-time
    # numbers in the parameter field (tiseg.model.physics.param_layout), so a new term needs
    # no field here
    sources: tuple[str, ...] = field(default=(), metadata=from_keys("effects.sources"))
    # a bed b(x, y) under the flow, balanced by the hydrostatic reconstruction
    # (tiseg.solver.numerics.bed): on when truthy (the scene's terrain, compared by
    # set_parameters; True in a config built by hand); its heights are given to the operator
    # (set_bed)
    bed: object = field(default=None, metadata=from_keys(*_TERRAIN, what="the terrain"))
    # solid cells (obstacles, raster nodata) whose faces are walls (tiseg.solver.numerics.walls)
    solid: bool = field(default=False, metadata=from_keys(*_TERRAIN, what="the terrain"))
    # a reference surface that bends (terrain.runout): (zeta2 [rad], x_b [m], L [m]) of the
    # bend from zeta to zeta2 (tiseg.model.bed_line, tiseg.solver.numerics.gravity); None: the
    # plane of the paper, whose gravity is two run-time numbers
    bend: tuple | None = field(default=None, metadata=from_keys("terrain.runout"))
    constants: tuple[tuple[str, float], ...] = ()

    def __post_init__(self):
        """Checked also when the config is built by hand, not from a scene: the registries as
        they stand now (a component registered by user code counts), InputErrors (kept under
        ``python -O``)."""
        for key, value in (
            ("effects.friction", self.friction),
            ("material.transport", self.transport),
            ("numerics.reconstruction", self.reconstruction),
            ("numerics.flux", self.flux),
            ("numerics.phi_flux", self.phi_flux),
            *(("boundary", b) for b in self.bc),
            *(("effects.sources", name) for name in self.sources),
        ):
            check_choice(key, value, REGISTRIES[key])
        for name in self.sources:
            if SOURCES[name].stencil > MAX_STENCIL:
                raise InputError(
                    f"effects.sources: the term {name!r} reads {SOURCES[name].stencil} cells "
                    f"along each direction; the operator gives a term at most {MAX_STENCIL}"
                )
        given = dict(self.constants)
        for comp in components(self.sources):
            missing = [c.name for c in comp.constants if c.name not in given]
            if missing:
                raise InputError(f"{comp.name!r} needs the constants {missing}: give them")
        check_choice("numerics.friction_scheme", self.friction_scheme, FRICTION_SCHEMES)
        regularised = self.friction != "none" and not self.friction_projected
        if self.split and regularised:
            raise InputError(
                "a split stepper takes friction only as the projection: "
                'numerics.friction_scheme = "projected"'
            )

    @property
    def friction_projected(self) -> bool:
        """Friction as a projection after each stage: the projected scheme, and a law."""
        return self.friction_scheme == "projected" and self.friction != "none"

    @property
    def g_cos(self) -> float:
        return self.g * math.cos(self.zeta)

    @property
    def g_sin(self) -> float:
        return self.g * math.sin(self.zeta)

    def bed_line(self):
        """The bend's `tiseg.model.bed_line.BedLine` (None on a plane)."""
        if self.bend is None:
            return None
        zeta2, x_b, length = self.bend
        return BedLine(self.zeta, zeta2, x_b, length)

    @property
    def segregation(self) -> bool:
        return self.layout.segregation

    def inflow_phi_profile(self, y) -> np.ndarray:
        """Inflow concentration (6.9) + noise at cross-slope positions y [m]."""
        return inflow_concentration(
            y,
            self.Ly,
            self.inflow_phi,
            self.inflow_delta,
            self.inflow_modes,
            self.inflow_noise,
            self.inflow_seed,
        )

    def inflow_state(self, t: float) -> tuple[float, float, float]:
        """(h, u, phi) of the inflow (6.8) at time t; h = 0 once the inflow has stopped."""
        if t > self.inflow_stop:
            return 0.0, 0.0, self.inflow_phi
        ramp = 1.0 if self.inflow_ramp <= 0 else -math.expm1(-self.inflow_ramp * t)
        force = inflow_forcing(t, self.inflow_forcing_frequency, self.inflow_forcing_amplitude)
        return ramp * force * self.inflow_h, self.inflow_u, self.inflow_phi


# OperatorConfig fields made from scene keys -> (those keys, the change in words)
FIELD_KEYS = {
    f.name: (f.metadata["keys"], f.metadata["what"]) for f in fields(OperatorConfig) if f.metadata
}


def compiled_fields(compiled_keys) -> dict[str, str]:
    """{field: the change in words} of the OperatorConfig fields the kernels are compiled for:
    those made from a scene key in ``compiled_keys`` (the schema's operator-compiled keys,
    `tiseg.setup.schema.compiled_keys`)."""
    keys = set(compiled_keys)
    return {name: what for name, (made_of, what) in FIELD_KEYS.items() if keys & set(made_of)}


def config_from_scene(scene) -> OperatorConfig:
    """The operator's view of a `tiseg.setup.scene.Scene`."""
    m = scene.material
    lay = Layout(scene.domain.nx, scene.domain.ny, bool(scene.segregation))
    # the effects' constants: the friction laws' go to FrictionParams, the source terms' and
    # their fields' to `constants`
    given = dict(scene.effects.constants)
    sources = tuple(scene.effects.sources)
    own = {c.name for comp in components(sources) for c in comp.constants}
    fric = FrictionParams.of(m, **{k: v for k, v in given.items() if k not in own})
    u_ref = scene.flow.u0 or math.sqrt(m.g * scene.flow.h0 * max(math.cos(m.zeta), 1e-3))
    kw = {}
    inflow = scene.inflow
    if inflow is not None:
        kw = dict(
            inflow_h=inflow.h,
            inflow_u=inflow.u,
            inflow_phi=inflow.phi,
            inflow_ramp=inflow.ramp_rate,
            inflow_delta=inflow.perturbation,
            inflow_modes=inflow.modes,
            inflow_noise=inflow.noise,
            inflow_seed=inflow.seed,
            inflow_stop=math.inf if inflow.stop_time is None else inflow.stop_time,
            inflow_forcing_frequency=inflow.forcing_frequency,
            inflow_forcing_amplitude=inflow.forcing_amplitude,
            inflow_rows=inflow.rows(scene.domain.ny, scene.domain.dy),
        )
    num = scene.numerics
    return OperatorConfig(
        layout=lay,
        dx=scene.domain.dx,
        dy=scene.domain.dy,
        Ly=scene.domain.Ly,
        viscous=bool(scene.viscous),
        feedback=bool(scene.feedback),
        friction=scene.effects.friction,
        g=m.g,
        zeta=m.zeta,
        transport=m.transport,
        alpha=m.alpha,
        nu=scene.acting_nu,
        phi_ref=scene.flow.phi0,
        fric=fric,
        reconstruction=num.reconstruction,
        theta=num.theta,
        flux=num.flux,
        phi_flux=num.phi_flux,
        h_ref=scene.flow.h0,
        u_ref=u_ref,
        h_min=num.h_min,
        h_eps=num.h_eps,
        u_eps=num.u_eps,
        friction_scheme=num.friction_scheme,
        local_step_rate=num.step_rule == "local" and not lay.is_1d,
        split=is_split(num.stepper),
        bc=scene.boundary.as_tuple(),
        sources=sources,
        constants=tuple((k, v) for k, v in given.items() if k in own),
        bed=scene.terrain if scene.has_terrain else None,
        solid=bool(scene.has_terrain and scene.bed_arrays()[1].any()),
        bend=_bend(scene.terrain.runout),
        **kw,
    )


def _bend(runout) -> tuple | None:
    """OperatorConfig.bend of a scene's ``[terrain.runout]`` (None without one)."""
    if runout is None:
        return None
    return (math.radians(runout.zeta_deg), runout.x, runout.length)
