"""Scenes: a simulation set-up as a TOML file, validated into one frozen :class:`Scene`.

A scene describes everything a run needs: the material (Table 1), the reference steady uniform
flow of section 4, which physical effects are switched on, the domain and its boundaries, the
inflow (6.8)-(6.9), the initial state (e.g. the empty slope (6.7)), the numerics, the end time and
the output times. Built-in scenes live in ``tiseg/data/scenes/*.toml`` (see :func:`list_builtin_scenes`);
any other TOML file can be given by path.

Loading is strict, because a typo in a scene would otherwise silently run the wrong experiment:
unknown sections and keys, wrong types, out-of-range values and inconsistent combinations all raise
:class:`tiseg.errors.InputError` with a message that names the full dotted key, the bad value and
what is allowed. Nothing given is ever ignored without saying so.

Command-line style overrides (``--set section.key=value``) are applied to the raw TOML data
before validation, so an override is checked exactly like the same value written in the file::

    scene = load_scene("fingers", ["domain.resolution=250", "time.t_end=2.0"])

:meth:`Scene.to_toml` writes the fully resolved scene (every default filled in) as TOML that
:func:`load_scene` turns back into an equal :class:`Scene`; a run stores it next to its output so
that the run can be repeated exactly.
"""

from __future__ import annotations

import difflib
import math
import numbers
import re
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np
import tomli_w

from .errors import InputError
from .paths import check_name, safe_name
from .material import Material, Species
from .physics.friction import FRICTION_LAWS as _LAWS
from .numerics.config import (
    FLUXES,
    FRICTION_LAWS as _FRICTION_LAWS,
    FRICTION_SCHEMES,
    PHI_FLUXES,
    SPLIT_CFL,
    SPLIT_STEPPERS,
    STEP_RULES,
    TRANSPORTS as _TRANSPORTS,
    inflow_concentration,
    noise_modes,
)
from .steady import steady_state
from .timestepping import STEPPERS as _STEPPER_REGISTRY

from .data import SCENE_DIR, builtin_file, builtin_names

# ---- allowed choices ----------------------------------------------------------------------------
FRICTION_LAWS = _FRICTION_LAWS  # effects.friction: the registry of tiseg.physics.friction
TRANSPORTS = _TRANSPORTS  # material.transport: the registry of tiseg.physics.segregation
RECONSTRUCTIONS = ("weno", "minmod", "first-order")
OUTPUT_PRECISIONS = ("f8", "f4")
RECONSTRUCTION_ALIASES = {"first_order": "first-order", "first": "first-order"}
STEPPERS = tuple(_STEPPER_REGISTRY)  # numerics.stepper: every registered stepper
PRECISIONS = ("f64", "f32")
BOUNDARY_KINDS = ("inflow", "outflow", "periodic", "wall")
INITIAL_KINDS = ("empty", "uniform", "dam-break", "release", "channel")
PERTURBATION_MODES = ("eigen", "h", "phi", "noise")

# Keys each initial kind accepts; a key of another kind is an error (it would otherwise be unused).
INITIAL_KEYS = {
    "empty": ("kind",),
    "uniform": ("kind", "amplitude", "k", "ky", "mode", "seed", "wavelengths"),
    "dam-break": ("kind", "x0", "h_left", "h_right", "phi"),
    "release": ("kind", "x0", "x1", "y0", "y1", "h", "phi"),
    "channel": ("kind", "width", "phi_channel", "phi_levee", "h"),
}

SECTION_KEYS = {
    "material": (
        "zeta_deg",
        "alpha",
        "transport",
        "g",
        "chi",
        "beta_star",
        "kappa",
        "small",
        "large",
    ),
    "flow": ("h0", "phi0", "nu", "u0"),
    "effects": ("segregation", "mobility_feedback", "viscosity", "friction", "coulomb_mu"),
    "domain": ("Lx", "Ly", "resolution", "nx", "ny"),
    "boundary": ("x_lo", "x_hi", "y_lo", "y_hi"),
    "inflow": ("h", "u", "phi", "ramp_rate", "perturbation", "modes", "stop_time", "noise", "seed"),
    "initial": tuple(dict.fromkeys(k for keys in INITIAL_KEYS.values() for k in keys)),
    "numerics": (
        "reconstruction",
        "theta",
        "flux",
        "phi_flux",
        "stepper",
        "cfl",
        "step_rule",
        "precision",
        "h_min",
        "h_eps",
        "u_eps",
        "friction_scheme",
        "max_stages",
    ),
    "time": ("t_end",),
    "output": ("interval", "times", "checkpoint_interval", "precision", "significant_digits"),
}
TOP_LEVEL_KEYS = ("name", "description") + tuple(SECTION_KEYS)
SPECIES_KEYS = ("zeta1_deg", "zeta2_deg", "beta", "L", "zeta3_deg")

DEFAULT_COULOMB_MU = math.tan(math.radians(20.0))
MIN_CELLS = 4  # a periodic axis needs at least 2 x GHOST(=2) interior cells
MIN_CELLS_PER_PERTURBATION = 4  # cells across one wavelength Ly/modes of the inflow (6.9)
MAX_CELLS = 2**31 - 1  # Taichi fields are indexed with 32-bit integers
MAX_NU = 1e3  # [m^(3/2)/s] largest viscosity coefficient accepted
# Lower bounds of numbers that would otherwise be accepted and never finish or fail later:
# the number of steps grows as 1 / numerics.cfl: below MIN_CFL a run takes more than 500 times
# the steps of the default 0.5 (numerics.cfl = 1e-300 never finished)
MIN_CFL = 1e-3
# the velocity's desingularisation divides by h^4 + max(h^4, h_eps^4): h_eps^4 must remain a
# normal number in f32 (1e-9^4 = 1e-36 > 1.2e-38), else dry cells give 0/0 = NaN at step 1
MIN_H_EPS = 1e-9
MAX_NESTING = 16  # levels of tables and arrays: a scene needs 3, a deeper one is refused
MAX_OUTPUT_TIMES = 1_000_000  # snapshots or checkpoint times: guards against interval = 1e-12

_MISSING = object()


# =================================================================================================
# The configuration
# =================================================================================================
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

    h0: float = 0.002  # thickness of the reference steady uniform flow [m]
    phi0: float = 0.8  # its small-particle concentration, in [0, 1]
    nu: float = 0.01  # [m^(3/2)/s], coefficient of the viscous term of (6.2)
    u0: float | None = None  # its speed [m/s]: derived from (4.3), (4.9) for the
    # pouliquen-mixture friction, else give it
    F: float | None = None  # Froude number (4.3)
    no_steady: str | None = field(default=None, compare=False)


@dataclass(frozen=True)
class EffectsConfig:
    """Which physics is switched on; see the resolved properties on :class:`Scene`."""

    segregation: bool = True  # large-particle transport (6.3); false: no phi field
    mobility_feedback: bool = True  # friction (3.4) uses the local phi, else flow.phi0
    viscosity: bool = True  # the nu h^(3/2) D term of (6.2)
    friction: str = "pouliquen-mixture"  # one of FRICTION_LAWS
    coulomb_mu: float = DEFAULT_COULOMB_MU  # constant friction coefficient for "coulomb"


@dataclass(frozen=True)
class DomainConfig:
    """Rectangle x in [0, Lx] (downslope), y in [0, Ly] (cross-slope) of nx x ny cells."""

    Lx: float  # downslope length [m]
    Ly: float  # cross-slope width [m]
    nx: int  # cells downslope (or give resolution)
    ny: int  # cells across the slope; 1 = a 1D run
    resolution: float | None = None  # cells per metre, only used to derive nx, ny

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


@dataclass(frozen=True)
class BoundaryConfig:
    x_lo: str = "inflow"  # upslope edge x = 0: inflow (6.8) needs an [inflow] table
    x_hi: str = "outflow"  # downslope edge x = Lx
    y_lo: str = "periodic"  # cross-slope edge y = 0
    y_hi: str = "periodic"  # cross-slope edge y = Ly (periodic needs both sides periodic)

    def as_tuple(self) -> tuple[str, str, str, str]:
        """(x_lo, x_hi, y_lo, y_hi), the order of ``OperatorConfig.bc``."""
        return (self.x_lo, self.x_hi, self.y_lo, self.y_hi)


@dataclass(frozen=True)
class InflowConfig:
    """Inflow at x = 0, (6.8)-(6.9):

    h(0, y, t) = (1 - exp(-ramp_rate t)) h,  u = u,  v = 0,
    phi(0, y, t) = phi + perturbation sin(2 pi modes y / Ly) + noise phi r(y),

    switched off (h = 0) for t > stop_time when a finite release is modelled. In a 1D run the
    single cell row has its centre at y = Ly/2, where the perturbation sin(pi modes) vanishes.

    ``noise`` (default 0) adds a random cross-slope profile r(y) of unit RMS, band-limited to
    wavelengths of 2 cm and more and the same on every grid
    (:func:`tiseg.numerics.config.inflow_noise`), drawn from ``seed``: without it the
    symmetry of (6.9) is broken by round-off alone, so the finger pattern of one run is one
    draw that changes with any change of the numerics; with it, runs that differ only in
    ``seed`` are physically different realisations (ensembles, ``tiseg sweep``).
    """

    h: float  # inflow thickness [m] (default flow.h0)
    u: float  # inflow speed [m/s] (default flow.u0)
    phi: float  # inflow concentration of (6.9) (default flow.phi0)
    ramp_rate: float = 10.0  # [1/s]; 0 = sudden inflow
    perturbation: float = 8e-5  # delta of (6.9)
    modes: int = 1  # number of sine periods across Ly
    stop_time: float | None = None  # [s]; None = continuous inflow
    noise: float = 0.0  # relative RMS amplitude of the random profile
    seed: int = 0  # realisation of the random profile

    def thickness(self, t: float) -> float:
        """Inflow thickness at time t, (6.8a); 0 after ``stop_time``."""
        if self.stop_time is not None and t > self.stop_time:
            return 0.0
        ramp = 1.0 if self.ramp_rate <= 0 else -math.expm1(-self.ramp_rate * t)
        return ramp * self.h

    def concentration(self, y, Ly: float):
        """Inflow concentration (6.8d), (6.9) plus the noise at cross-slope positions y [m]."""
        return inflow_concentration(
            y, Ly, self.phi, self.perturbation, self.modes, self.noise, self.seed
        )


@dataclass(frozen=True)
class InitialConfig:
    """Initial state; only the fields of ``kind`` are set, the others are None.

    * empty: the empty slope (6.7).
    * uniform: the steady uniform state (h0, u0, phi0) plus a perturbation of relative
      ``amplitude`` with dimensionless wavenumbers ``k`` (downslope) and ``ky`` (cross-slope) in
      the scalings (5.1), i.e. k_SI = k / h0; ``mode`` "eigen" is the most unstable linear mode
      (computed by the simulation), "h"/"phi" perturb one field, "noise" is random (``seed``).
      ``wavelengths`` = Lx k_SI / (2 pi), the number of downslope wavelengths in the domain.
    * dam-break: h = h_left for x < x0, h_right beyond, at rest, concentration ``phi``.
    * release: a block [x0, x1] x [y0, y1] of thickness h and concentration phi, at rest.
    * channel: a layer of thickness h at rest, with one straight downslope channel of
      concentration ``phi_channel`` and ``width`` centred at y = Ly/2 between levees of
      ``phi_levee`` (the verification case of sharp contacts, :mod:`tiseg.steady_channel`).
    """

    kind: str = "empty"  # which initial state (the list above)
    amplitude: float | None = None  # uniform: relative perturbation amplitude, < 1
    k: float | None = None  # uniform: downslope wavenumber in the scalings (5.1)
    ky: float | None = None  # uniform: cross-slope wavenumber, (5.1) scalings
    mode: str | None = None  # uniform: eigen (most unstable mode), h, phi or noise
    seed: int | None = None  # uniform: random seed of mode = "noise"
    wavelengths: float | None = None  # uniform: downslope wavelengths in Lx (sets Lx)
    x0: float | None = None  # dam-break: dam position; release: block start [m]
    x1: float | None = None  # release: block end [m]
    y0: float | None = None  # release: block start across the slope [m]
    y1: float | None = None  # release: block end across the slope [m]
    h_left: float | None = None  # dam-break: thickness upslope of x0 [m]
    h_right: float | None = None  # dam-break: thickness downslope of x0 [m]
    h: float | None = None  # release, channel: thickness [m] (default flow.h0)
    phi: float | None = None  # dam-break, release: concentration (default flow.phi0)
    width: float | None = None  # channel: width of the channel at y = Ly/2 [m]
    phi_channel: float | None = None  # channel: concentration in the channel (default 1)
    phi_levee: float | None = None  # channel: concentration in the levees (default 0)


@dataclass(frozen=True)
class NumericsConfig:
    reconstruction: str = "weno"  # "weno" (a WENO-type slope; docs/numerics.md says how it
    # differs from Noelle 2000's), "minmod", "first-order"
    theta: float = 1.5  # generalised minmod parameter, in [1, 2]
    flux: str = "kt"  # "kt" (Kurganov-Tadmor 2000, as in section 6.2) or
    # "central-upwind" (Kurganov, Noelle & Petrova 2001)
    phi_flux: str = "upwind"  # h phi flux: the mass flux times the upwind phi - G(phi)
    # ("upwind", keeps contacts sharp), or the flux scheme's own ("central", the paper's)
    stepper: str = "rkc"  # Runge-Kutta-Chebyshev as in section 6.2, or SSP RK / Euler, or
    # "hancock": dimensionally split MUSCL-Hancock sweeps (no viscosity, no friction)
    cfl: float = 0.25  # Courant number of the hyperbolic part, in [0.001, 1]; 0.25 with
    # step_rule "max", 0.5 with "sum" and "local" (each rule's forward-Euler positivity bound),
    # 0.6 with stepper "hancock" (each sweep is stable up to 1; h >= 0 whatever the step)
    step_rule: str = "max"  # "max": dt = cfl min(dx/a, dy/b); "sum": dt = cfl / (a/dx + b/dy);
    # "local": dt = cfl / max over cells of (a/dx + b/dy), a and b from the cell's faces
    # (Kurganov & Petrova 2007; up to 2x longer steps where one direction dominates)
    precision: str = "f64"  # floating-point precision of the kernels
    h_min: float = 1e-4  # fluxes vanish where h < h_min (section 6.2) [m]
    h_eps: float = 1e-7  # desingularisation thickness for u = hu / h [m], >= 1e-9, < h_min
    u_eps: float = 1e-3  # regularises the friction direction u / |u| [m/s] ("regularised")
    friction_scheme: str = "projected"  # basal friction as a projection: after each stage a
    # cell's momentum shrinks by the friction impulse and stops exactly where the impulse can
    # cancel it (Mangeney et al. 2007), so material comes to rest and stays there; or
    # "regularised": an explicit source with u / max(|u|, u_eps) (section 6.2), under which
    # material that friction should hold creeps at up to u_eps (SSP steppers only)
    max_stages: int = 200  # upper bound on the number of RKC stages


@dataclass(frozen=True)
class TimeConfig:
    t_end: float  # end time of the run [s]


@dataclass(frozen=True)
class OutputConfig:
    """Snapshot times. ``output_times`` is the resolved, sorted union of ``times``, the multiples
    of ``interval`` up to t_end, t = 0 and t_end."""

    interval: float | None = None  # a snapshot every interval seconds, >= t_end / 1e6 [s]
    times: tuple[float, ...] = ()  # snapshots at these times too [s]
    checkpoint_interval: float | None = None  # simulated seconds between checkpoints,
    # >= t_end / 1e6 [s]
    output_times: tuple[float, ...] = ()
    precision: str | None = None  # fields.nc data type: "f8", "f4"; None: the run's precision
    significant_digits: int | None = None  # quantise fields.nc to this many decimal digits

    def dtype(self, run_precision: str) -> str:
        """NetCDF type of the stored fields for a run in ``run_precision`` ("f64"/"f32")."""
        if self.precision is not None:
            return self.precision
        return "f8" if run_precision == "f64" else "f4"


@dataclass(frozen=True)
class Scene:
    """A fully validated simulation set-up; build it with :func:`load_scene`."""

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
            and _LAWS[self.effects.friction].weighted
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
        _apply_overrides(data, overrides)
        return _build_labelled(data, self.name, self.source, f"{self.name!r}")


# =================================================================================================
# Public functions
# =================================================================================================
def list_builtin_scenes() -> list[str]:
    """Names of the scenes shipped in the package (``tiseg/data/scenes``)."""
    return builtin_names(SCENE_DIR)


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
        raise InputError(f"override {text!r}: expected 'section.key=value' (no '=' found)")
    _check_dotted_key(key, text)
    if "\n" in raw or "\r" in raw:
        raise InputError(f"override {text!r}: the value must be on one line")
    try:
        doc = tomllib.loads(f"v = {raw}", parse_float=_toml_float)
    except tomllib.TOMLDecodeError:
        return key, raw  # a bare word such as `weno`: take it as a string
    except RecursionError:
        raise InputError(f"override {key!r}: the value nests too deeply") from None
    if set(doc) != {"v"}:  # e.g. `1 \n x = 2` smuggling a second key
        return key, raw
    return key, doc["v"]


def load_scene(name_or_path, overrides=None) -> Scene:
    """Load and validate a scene.

    ``name_or_path``: a built-in scene name (no '/' and no '.toml', see
    :func:`list_builtin_scenes`), a path to a TOML file, or a :class:`Scene` (then only the
    overrides are applied). ``overrides``: a dict ``{"section.key": value}`` (a value of None
    removes the key) or a list of ``"section.key=value"`` strings (``--set``).
    """
    if isinstance(name_or_path, Scene):
        return name_or_path.with_overrides(overrides) if overrides else name_or_path
    path = _resolve_scene_path(name_or_path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"scene file {str(path)!r} is not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise InputError(
            f"cannot read scene file {str(path)!r}: {exc.strerror or exc}; "
            f"built-in scenes: {', '.join(list_builtin_scenes())}"
        ) from None
    # error messages name a built-in scene by its name, any other file by its path
    builtin = path.resolve().parent == SCENE_DIR
    return scene_from_text(
        text,
        name=path.stem,
        overrides=overrides,
        source=str(path),
        label=repr(path.stem) if builtin else None,
    )


def scene_from_text(
    text: str,
    name: str = "scene",
    overrides=None,
    source: str | None = None,
    label: str | None = None,
) -> Scene:
    """Validate a scene given as TOML text (``name`` is the default for the top-level name)."""
    where = source or "<text>"
    try:
        data = tomllib.loads(text, parse_float=_toml_float)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"scene file {where!r} is not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"scene file {where!r} nests arrays or tables too deeply") from None
    return scene_from_dict(data, name=name, overrides=overrides, source=source, label=label)


def scene_from_dict(
    data: Mapping,
    name: str = "scene",
    overrides=None,
    source: str | None = None,
    label: str | None = None,
) -> Scene:
    """Validate a scene given as the nested dict a TOML file parses to."""
    if not isinstance(data, Mapping):
        raise InputError(f"a scene must be a table of sections, got {_type_name(data)}")
    label = label or (repr(source) if source else repr(name))
    try:
        data = _deep_copy(data)
        _apply_overrides(data, overrides)
    except InputError as exc:
        raise InputError(f"scene {label}: {exc}") from None
    return _build_labelled(data, name, source, label)


def scene_to_dict(scene: Scene, derived: bool = False) -> dict:
    """The resolved scene as the nested dict of its TOML form (None values are left out, as TOML
    has no null). With ``derived=True`` a ``derived`` table with u0, F, dx, dy, the output times
    and the resolved switches is added (that dict is for reports, not for loading)."""
    m = scene.material
    material = {k: v for k, v in m.as_dict().items() if k not in ("small", "large")}
    for sp_name in ("small", "large"):
        sp: Species = getattr(m, sp_name)
        material[sp_name] = sp.as_dict()
    flow = {"h0": scene.flow.h0, "phi0": scene.flow.phi0, "nu": scene.flow.nu}
    if not _LAWS[scene.effects.friction].steady and scene.flow.u0 is not None:
        flow["u0"] = scene.flow.u0  # user-given; with the mixture law it is derived
    e = scene.effects
    dom = scene.domain
    # With a resolution the cell counts are derived from it (and left out, so that an override
    # of Lx or Ly on the resolved scene re-derives them); a 1D run keeps its explicit ny = 1.
    domain = {"Lx": dom.Lx, "Ly": dom.Ly}
    if dom.resolution is not None:
        domain["resolution"] = dom.resolution
    else:
        domain["nx"] = dom.nx
    if dom.resolution is None or dom.is_1d:
        domain["ny"] = dom.ny
    b = scene.boundary
    n = scene.numerics
    out = scene.output
    output: dict = {}
    if out.interval is not None:
        output["interval"] = out.interval
    output["times"] = list(out.times)
    if out.checkpoint_interval is not None:
        output["checkpoint_interval"] = out.checkpoint_interval
    if out.precision is not None:
        output["precision"] = out.precision
    if out.significant_digits is not None:
        output["significant_digits"] = out.significant_digits
    d: dict = {
        "name": scene.name,
        "description": scene.description,
        "material": material,
        "flow": flow,
        "effects": {
            "segregation": e.segregation,
            "mobility_feedback": e.mobility_feedback,
            "viscosity": e.viscosity,
            "friction": e.friction,
            "coulomb_mu": e.coulomb_mu,
        },
        "domain": domain,
        "boundary": {"x_lo": b.x_lo, "x_hi": b.x_hi, "y_lo": b.y_lo, "y_hi": b.y_hi},
    }
    if scene.inflow is not None:
        i = scene.inflow
        inflow = {
            "h": i.h,
            "u": i.u,
            "phi": i.phi,
            "ramp_rate": i.ramp_rate,
            "perturbation": i.perturbation,
            "modes": i.modes,
            "noise": i.noise,
            "seed": i.seed,
        }
        if i.stop_time is not None:
            inflow["stop_time"] = i.stop_time
        d["inflow"] = inflow
    ini = scene.initial
    d["initial"] = {
        k: getattr(ini, k) for k in INITIAL_KEYS[ini.kind] if getattr(ini, k) is not None
    }
    d["numerics"] = {
        "reconstruction": n.reconstruction,
        "theta": n.theta,
        "flux": n.flux,
        "phi_flux": n.phi_flux,
        "stepper": n.stepper,
        "cfl": n.cfl,
        "step_rule": n.step_rule,
        "precision": n.precision,
        "h_min": n.h_min,
        "h_eps": n.h_eps,
        "u_eps": n.u_eps,
        "friction_scheme": n.friction_scheme,
        "max_stages": n.max_stages,
    }
    d["time"] = {"t_end": scene.time.t_end}
    d["output"] = output
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


# =================================================================================================
# Building and validation
# =================================================================================================
def _resolve_scene_path(name_or_path) -> Path:
    if not isinstance(name_or_path, (str, Path)):
        raise InputError(f"scene {name_or_path!r}: expected a built-in scene name or a path")
    found = builtin_file(name_or_path, SCENE_DIR, "scene")
    if found is not None:
        return found
    text = str(name_or_path)
    builtins = list_builtin_scenes()
    path = Path(text).expanduser()
    if path.is_dir():
        raise InputError(
            f"scene {text!r} is a folder, not a scene file (give a .toml file; "
            "to continue a run in a folder: tiseg run --resume DIR)"
        )
    if path.exists() and not path.is_file():
        raise InputError(
            f"scene {text!r} is not a regular file (a pipe or device?); give a .toml file"
        )
    if not path.is_file():
        raise InputError(
            f"scene file {text!r} not found; built-in scenes: {', '.join(builtins) or '(none)'}"
        )
    return path


def _build_labelled(data: dict, name: str, source: str | None, label: str) -> Scene:
    try:
        return _build(data, name, source)
    except InputError as exc:
        raise InputError(f"scene {label}: {exc}") from None


def _build(data: dict, default_name: str, source: str | None) -> Scene:
    top = _Table(data, "", TOP_LEVEL_KEYS)
    if top.has("name"):
        name = check_name(top.string("name", default_name))
    else:
        name = safe_name(default_name)  # a file's stem: made safe, not refused
    description = top.string("description", "")

    material = _read_material(top.table("material"))
    effects = _read_effects(top.table("effects"))
    flow = _read_flow(top.table("flow"), material, effects)

    ini_t = top.table("initial")
    kind = ini_t.choice("kind", INITIAL_KINDS, "empty")
    ini_t.only(INITIAL_KEYS[kind], f"initial.kind={kind!r}")

    time = TimeConfig(t_end=top.table("time").number("t_end", positive=True))
    domain, wavelengths = _read_domain(top.table("domain"), ini_t, kind, flow)
    boundary = _read_boundary(top.table("boundary"), domain)
    inflow = _read_inflow(top.table("inflow"), top.has("inflow"), boundary, domain, flow)
    initial = _read_initial(ini_t, kind, wavelengths, domain, boundary, flow, effects)
    numerics = _read_numerics(top.table("numerics"), flow, domain.ny == 1, effects)
    output = _read_output(top.table("output"), time.t_end)
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
        source=source,
    )


def _read_material(t: "_Table") -> Material:
    base = Material()
    kw: dict = {
        "zeta_deg": t.number("zeta_deg", base.zeta_deg),
        "alpha": t.number("alpha", base.alpha),
        "transport": t.choice("transport", TRANSPORTS, base.transport),
        "g": t.number("g", base.g, positive=True),
        "chi": t.number("chi", base.chi),
        "beta_star": t.number("beta_star", base.beta_star, positive=True),
        "kappa": t.number("kappa", base.kappa, positive=True),
    }
    for sp_name in ("small", "large"):
        st = t.table(sp_name, SPECIES_KEYS)
        sp0: Species = getattr(base, sp_name)
        kw[sp_name] = Species(
            zeta1_deg=st.number("zeta1_deg", sp0.zeta1_deg),
            zeta2_deg=st.number("zeta2_deg", sp0.zeta2_deg),
            beta=st.number("beta", sp0.beta, positive=True),
            L=st.number("L", sp0.L, positive=True),
            zeta3_deg=st.number("zeta3_deg", None),
        )
    return Material(**kw)  # checks the remaining ranges, naming material.<key>


def _read_effects(t: "_Table") -> EffectsConfig:
    return EffectsConfig(
        segregation=t.boolean("segregation", True),
        mobility_feedback=t.boolean("mobility_feedback", True),
        viscosity=t.boolean("viscosity", True),
        friction=t.choice("friction", FRICTION_LAWS, "pouliquen-mixture"),
        coulomb_mu=t.number("coulomb_mu", DEFAULT_COULOMB_MU, nonneg=True),
    )


def _read_flow(t: "_Table", material: Material, effects: EffectsConfig) -> FlowConfig:
    h0 = t.number("h0", 0.002, positive=True)
    phi0 = t.number("phi0", 0.8, lo=0.0, hi=1.0)
    nu = t.number("nu", 0.01, nonneg=True)
    # (6.2)'s coefficient is 0.01 m^(3/2)/s in the paper; beyond MAX_NU the viscous stiffness
    # nu sqrt(h) / dx^2 leaves no representable step on any grid (and overflows in the kernels)
    _require(
        nu <= MAX_NU,
        "flow.nu",
        nu,
        f"must be at most {MAX_NU:g} m^(3/2)/s (the paper "
        "uses 0.01); a larger viscosity leaves no time step that can advance",
    )
    law = effects.friction
    if _LAWS[law].steady:
        if t.has("u0"):
            raise InputError(
                f"flow.u0={_show(t.get('u0'))}: with effects.friction={law!r} u0 is "
                "derived from the steady uniform flow (4.3), (4.9) of h0 and phi0; remove flow.u0 "
                "(it may only be given for the other friction laws)"
            )
        try:
            st = steady_state(h0, phi0, material)
        except InputError as exc:
            why = (
                f"flow.h0={h0!r}, flow.phi0={phi0!r}: {exc}; effects.friction="
                f"{law!r} defines u0 only from a steady uniform flow (change flow.phi0 or "
                "material.zeta_deg)"
            )
            return FlowConfig(h0=h0, phi0=phi0, nu=nu, no_steady=why)
        except (ArithmeticError, ValueError) as exc:
            why = (
                f"flow.h0={h0!r}, flow.phi0={phi0!r}: no steady uniform flow for this "
                f"material ({exc})"
            )
            return FlowConfig(h0=h0, phi0=phi0, nu=nu, no_steady=why)
        if _LAWS[law].hysteresis and st.F < material.beta_star:
            # (4.3) is the steady flow of the dynamic regime only
            why = (
                f"flow.h0={h0!r}, flow.phi0={phi0!r}: the steady flow (4.3) has F = {st.F:.3g} "
                f"< material.beta_star = {material.beta_star:g}, outside the dynamic regime of "
                f"effects.friction={law!r}, which defines u0 only there (thicken flow.h0)"
            )
            return FlowConfig(h0=h0, phi0=phi0, nu=nu, no_steady=why)
        return FlowConfig(h0=h0, phi0=phi0, nu=nu, u0=st.u0, F=st.F)
    u0 = t.number("u0", None, positive=True)
    F = None if u0 is None else u0 / math.sqrt(material.g * h0 * material.cos_zeta)
    return FlowConfig(h0=h0, phi0=phi0, nu=nu, u0=u0, F=F)


def _read_domain(t: "_Table", ini: "_Table", kind: str, flow: FlowConfig):
    """Domain size and grid; also returns the number of downslope perturbation wavelengths of a
    uniform initial state (None for other kinds), since Lx and it determine each other."""
    k = wavelengths = None
    if kind == "uniform":
        k = ini.number("k", 0.0, nonneg=True)
        wavelengths = ini.number("wavelengths", None, positive=True)
    resolution = t.number("resolution", None, positive=True)
    if t.has("Lx"):
        Lx = t.number("Lx", positive=True)
        if k:
            implied = Lx * k / (2.0 * math.pi * flow.h0)
            if wavelengths is not None and not _close(implied, wavelengths):
                raise InputError(
                    f"domain.Lx={Lx!r} holds {implied:.6g} wavelengths of initial.k={k!r} "
                    f"(2 pi h0 / k = {2 * math.pi * flow.h0 / k:.6g} m) but "
                    f"initial.wavelengths={wavelengths!r}; give only one of them"
                )
            wavelengths = implied if wavelengths is None else wavelengths
    elif k:
        wavelengths = 1.0 if wavelengths is None else wavelengths
        Lx = wavelengths * 2.0 * math.pi * flow.h0 / k
    else:
        raise InputError(
            "domain.Lx is required (a positive length in metres"
            + (
                "; or give initial.k > 0 to size the domain by wavelengths)"
                if kind == "uniform"
                else ")"
            )
        )
    if kind == "uniform" and not k and wavelengths is not None:
        raise InputError(f"initial.wavelengths={wavelengths!r} needs initial.k > 0")

    nx = _grid_count(t, "nx", "Lx", Lx, resolution)
    if t.has("ny"):
        ny = t.integer("ny", lo=1)
    elif resolution is not None and t.has("Ly"):
        ny = _cells_of(t.number("Ly", positive=True), resolution, "domain.Ly")
        # only an explicit ny = 1 makes a 1D run; a derived count must resolve the width
        _require(
            ny >= MIN_CELLS,
            "domain.ny",
            ny,
            f"domain.resolution x domain.Ly gives {ny} cells across the slope; a 2D run "
            f"needs at least {MIN_CELLS} (give domain.ny = 1 for a 1D run)",
        )
    else:
        raise InputError(
            "domain.ny is required (1 for a 1D run), or give domain.Ly with domain.resolution"
        )
    if ny == 1:
        # 1D run: one cell row; its width is immaterial, dy = dx keeps the grid square.
        t.number("Ly", None, positive=True)  # still type-checked when given
        Ly = Lx / nx
    else:
        if not t.has("Ly"):
            raise InputError(f"domain.Ly is required for a 2D run (domain.ny={ny})")
        Ly = t.number("Ly", positive=True)
        if t.has("ny") and resolution is not None:
            _grid_count(t, "ny", "Ly", Ly, resolution)  # consistency check only
        _require(
            ny >= MIN_CELLS,
            "domain.ny",
            ny,
            f"a 2D run needs at least {MIN_CELLS} cells across the slope (or ny = 1 for 1D)",
        )
    _require(nx >= MIN_CELLS, "domain.nx", nx, f"needs at least {MIN_CELLS} cells")
    _require(
        nx * ny <= MAX_CELLS,
        "domain.nx * domain.ny",
        nx * ny,
        f"at most {MAX_CELLS} cells are supported",
    )
    return DomainConfig(Lx=Lx, Ly=Ly, nx=nx, ny=ny, resolution=resolution), wavelengths


def _cells_of(length: float, resolution: float, key: str) -> int:
    """round(length x resolution), refused when it overflows or exceeds MAX_CELLS."""
    n = length * resolution
    if not (math.isfinite(n) and n <= MAX_CELLS):
        raise InputError(
            f"{key}={length!r} at domain.resolution={resolution!r} gives {n:.3g} "
            f"cells; at most {MAX_CELLS} are supported"
        )
    return round(n)


def _grid_count(
    t: "_Table", key: str, length_key: str, length: float, resolution: float | None
) -> int:
    if resolution is not None:
        implied = _cells_of(length, resolution, f"domain.{length_key}")
        if t.has(key):
            n = t.integer(key, lo=1)
            if n != implied:
                raise InputError(
                    f"domain.{key}={n} disagrees with domain.resolution={resolution!r} x "
                    f"domain.{length_key}={length!r} = {implied} cells; change "
                    f"domain.resolution instead, or give domain.{key} without a resolution"
                )
            return n
        _require(
            implied >= 1,
            f"domain.{key}",
            implied,
            f"domain.resolution={resolution!r} x domain.{length_key}={length!r} gives no cells",
        )
        return implied
    if not t.has(key):
        raise InputError(f"domain.{key} or domain.resolution is required (cells in {length_key})")
    return t.integer(key, lo=1)


def _read_boundary(t: "_Table", domain: DomainConfig) -> BoundaryConfig:
    sides = {}
    for side, default in (
        ("x_lo", "inflow"),
        ("x_hi", "outflow"),
        ("y_lo", "periodic"),
        ("y_hi", "periodic"),
    ):
        v = t.choice(side, BOUNDARY_KINDS, default)
        if v == "inflow" and side != "x_lo":
            raise InputError(
                f"boundary.{side}='inflow': an inflow is only supported at x_lo "
                "(the top of the slope)"
            )
        sides[side] = v
    for lo, hi in (("x_lo", "x_hi"), ("y_lo", "y_hi")):
        if (sides[lo] == "periodic") != (sides[hi] == "periodic"):
            raise InputError(
                f"boundary.{lo}={sides[lo]!r}, boundary.{hi}={sides[hi]!r}: "
                "'periodic' must be given on both ends of an axis"
            )
    if domain.is_1d and sides["y_lo"] != "periodic":
        raise InputError(
            f"boundary.y_lo={sides['y_lo']!r}, boundary.y_hi={sides['y_hi']!r}: a "
            "1D run (domain.ny = 1) has no cross-slope boundaries; keep them "
            "'periodic'"
        )
    return BoundaryConfig(**sides)


def _read_inflow(
    t: "_Table", given: bool, boundary: BoundaryConfig, domain: DomainConfig, flow: FlowConfig
) -> InflowConfig | None:
    if boundary.x_lo != "inflow":
        if given:
            raise InputError(
                f"[inflow] is given but boundary.x_lo={boundary.x_lo!r}; set "
                "boundary.x_lo = 'inflow' or remove the [inflow] section"
            )
        return None
    h = t.number("h", flow.h0, positive=True)
    if not t.has("u") and flow.u0 is None:
        if flow.no_steady:
            raise InputError(
                f"{flow.no_steady}; the inflow velocity defaults to that u0, so give inflow.u"
            )
        raise InputError(
            "inflow.u is required: without a 'pouliquen-mixture' or 'pouliquen-extended' "
            "friction there is no derived steady velocity (give inflow.u or flow.u0)"
        )
    u = t.number("u", flow.u0, positive=True)
    phi = t.number("phi", flow.phi0, lo=0.0, hi=1.0)
    ramp = t.number("ramp_rate", 10.0, nonneg=True)
    delta = t.number("perturbation", 8e-5)
    modes = t.integer("modes", 1, lo=1)
    stop = t.number("stop_time", None, positive=True, allow_inf=True)
    if stop is not None and math.isinf(stop):
        stop = None  # inf = never stops = continuous inflow
    if not (0.0 <= phi - abs(delta) and phi + abs(delta) <= 1.0):
        raise InputError(
            f"inflow.perturbation={delta!r}: phi = inflow.phi={phi!r} +- "
            f"{abs(delta)!r} leaves [0, 1]; use a smaller perturbation (or 0)"
        )
    noise = t.number("noise", 0.0, nonneg=True)
    seed = t.integer("seed", 0, lo=0)
    if seed >= 2**63:
        raise InputError(f"inflow.seed={seed}: must be below 2**63")
    # the random profile never exceeds sqrt(2 N) in magnitude (inflow_noise)
    reach = abs(delta) + noise * phi * math.sqrt(2.0 * noise_modes(domain.Ly))
    if noise and not (0.0 <= phi - reach and phi + reach <= 1.0):
        raise InputError(
            f"inflow.noise={noise!r}: phi = inflow.phi={phi!r} + perturbation + "
            f"noise can reach {phi - reach:.4g}..{phi + reach:.4g}, outside [0, 1]; "
            "use a smaller noise (1e-4 is the scale of (6.9))"
        )
    if delta != 0.0 and not domain.is_1d:
        cells = domain.ny / modes
        if cells < MIN_CELLS_PER_PERTURBATION:
            raise InputError(
                f"inflow.modes={modes}: the perturbation (6.9) has a wavelength of Ly/modes = "
                f"{domain.ny / modes:.3g} cells (domain.ny={domain.ny}); at least "
                f"{MIN_CELLS_PER_PERTURBATION} cells are needed to resolve it (raise "
                "domain.resolution or domain.ny, or lower inflow.modes)"
            )
    return InflowConfig(
        h=h,
        u=u,
        phi=phi,
        ramp_rate=ramp,
        perturbation=delta,
        modes=modes,
        stop_time=stop,
        noise=noise,
        seed=seed,
    )


def _read_initial(
    t: "_Table",
    kind: str,
    wavelengths: float | None,
    domain: DomainConfig,
    boundary: BoundaryConfig,
    flow: FlowConfig,
    effects: EffectsConfig,
) -> InitialConfig:
    if kind == "empty":
        return InitialConfig(kind="empty")
    if kind == "uniform":
        if flow.no_steady:
            raise InputError(
                f"initial.kind='uniform' needs the steady uniform flow: {flow.no_steady}"
            )
        if flow.u0 is None:
            raise InputError(
                "initial.kind='uniform' needs the steady velocity u0: give flow.u0 "
                f"(effects.friction={effects.friction!r} does not define one)"
            )
        amplitude = t.number("amplitude", 0.0, lo=0.0)
        _require(
            amplitude < 1.0,
            "initial.amplitude",
            amplitude,
            "relative amplitude must be < 1 (h must stay positive)",
        )
        k = t.number("k", 0.0, nonneg=True)
        ky = t.number("ky", 0.0, nonneg=True)
        mode = t.choice("mode", PERTURBATION_MODES, "eigen")
        seed = t.integer("seed", 0, lo=0)
        if domain.is_1d and ky != 0.0:
            raise InputError(
                f"initial.ky={ky!r}: a 1D run (domain.ny = 1) has no cross-slope wavenumber; use 0"
            )
        if amplitude > 0 and mode != "noise" and k == 0.0 and ky == 0.0:
            raise InputError(
                f"initial.amplitude={amplitude!r} with initial.mode={mode!r} needs "
                "initial.k > 0 or initial.ky > 0"
            )
        if mode == "phi" and not effects.segregation:
            raise InputError(
                "initial.mode='phi' perturbs the concentration, but "
                "effects.segregation = false has no phi field"
            )
        if k and boundary.x_lo == "periodic" and not _near_integer(wavelengths):
            raise InputError(
                f"initial.wavelengths={wavelengths:.6g}: domain.Lx={domain.Lx!r} holds that many "
                f"wavelengths of initial.k={k!r}, but a periodic domain needs a whole number "
                "(set initial.wavelengths to an integer and leave domain.Lx out)"
            )
        if ky and boundary.y_lo == "periodic":
            ny_waves = domain.Ly * ky / (2.0 * math.pi * flow.h0)
            if not _near_integer(ny_waves):
                raise InputError(
                    f"initial.ky={ky!r}: domain.Ly={domain.Ly!r} holds {ny_waves:.6g} wavelengths; "
                    "a periodic domain needs a whole number (ky = 2 pi h0 n / Ly)"
                )
        return InitialConfig(
            kind=kind,
            amplitude=amplitude,
            k=k,
            ky=ky,
            mode=mode,
            seed=seed,
            wavelengths=wavelengths,
        )
    if kind == "dam-break":
        x0 = t.number("x0")
        _require(0.0 < x0 < domain.Lx, "initial.x0", x0, f"must lie inside (0, Lx={domain.Lx!r})")
        h_left = t.number("h_left", flow.h0, nonneg=True)
        h_right = t.number("h_right", 0.0, nonneg=True)
        _require(
            h_left > 0 or h_right > 0,
            "initial.h_left",
            h_left,
            "h_left and h_right cannot both be 0 (nothing would move)",
        )
        phi = t.number("phi", flow.phi0, lo=0.0, hi=1.0)
        return InitialConfig(kind=kind, x0=x0, h_left=h_left, h_right=h_right, phi=phi)
    if kind == "channel":
        _require(
            not domain.is_1d,
            "initial.kind",
            kind,
            "a channel lies across the slope: it needs a 2D domain (domain.ny > 1)",
        )
        width = t.number("width", positive=True)
        _require(
            width < domain.Ly,
            "initial.width",
            width,
            f"must be narrower than the chute, Ly={domain.Ly!r}",
        )
        phi_channel = t.number("phi_channel", 1.0, lo=0.0, hi=1.0)
        phi_levee = t.number("phi_levee", 0.0, lo=0.0, hi=1.0)
        h = t.number("h", flow.h0, positive=True)
        return InitialConfig(
            kind=kind, width=width, phi_channel=phi_channel, phi_levee=phi_levee, h=h
        )
    # release: a block of material at rest
    x0 = t.number("x0", lo=0.0)
    x1 = t.number("x1")
    _require(
        x0 < x1 <= domain.Lx, "initial.x1", x1, f"need initial.x0={x0!r} < x1 <= Lx={domain.Lx!r}"
    )
    y0 = t.number("y0", 0.0, lo=0.0)
    y1 = t.number("y1", domain.Ly)
    _require(
        y0 < y1 <= domain.Ly * (1 + 1e-12),
        "initial.y1",
        y1,
        f"need initial.y0={y0!r} < y1 <= Ly={domain.Ly!r}",
    )
    h = t.number("h", flow.h0, positive=True)
    phi = t.number("phi", flow.phi0, lo=0.0, hi=1.0)
    return InitialConfig(kind=kind, x0=x0, x1=x1, y0=y0, y1=y1, h=h, phi=phi)


def _read_numerics(
    t: "_Table", flow: FlowConfig, is_1d: bool, effects: EffectsConfig
) -> NumericsConfig:
    stepper = t.choice("stepper", STEPPERS, "rkc")
    split = stepper in SPLIT_STEPPERS
    rule = t.choice("step_rule", tuple(STEP_RULES), "max")
    n = NumericsConfig(
        reconstruction=t.choice(
            "reconstruction", RECONSTRUCTIONS, "weno", aliases=RECONSTRUCTION_ALIASES
        ),
        theta=t.number("theta", 1.5, lo=1.0, hi=2.0),
        flux=t.choice("flux", FLUXES, "kt"),
        phi_flux=t.choice("phi_flux", PHI_FLUXES, "upwind"),
        stepper=stepper,
        cfl=t.number("cfl", SPLIT_CFL if split else STEP_RULES[rule], positive=True, hi=1.0),
        step_rule=rule,
        precision=t.choice("precision", PRECISIONS, "f64"),
        h_min=t.number("h_min", 1e-4, positive=True),
        h_eps=t.number("h_eps", 1e-7, positive=True),
        u_eps=t.number("u_eps", 1e-3, positive=True),
        friction_scheme=t.choice("friction_scheme", FRICTION_SCHEMES, "projected"),
        max_stages=t.integer("max_stages", 200, lo=2),
    )
    if split:
        _check_split(n, flow, effects)
        if rule != "max" and not is_1d:
            from .log import note

            note(
                f"numerics.step_rule={rule!r} with stepper {stepper!r}: each sweep needs only its "
                "own direction's Courant number, so step_rule = 'max' allows steps up to 2x "
                "longer at the same numerics.cfl"
            )
    else:
        _check_friction_scheme(n, effects)
        # the max rule's bound is the sum rule's in 1D, where a_y plays no part
        bound = STEP_RULES["sum"] if is_1d else STEP_RULES[rule]
        if n.cfl > bound * (1 + 1e-12):
            from .log import note

            note(
                f"numerics.cfl={n.cfl:g} is above the positivity bound {bound:g} of step_rule "
                f"{rule!r}{' in 1D' if is_1d else ''}: h may turn negative at dry fronts, where "
                "the stage limiter clips it and mass is then not conserved exactly"
            )
    _require(
        n.cfl >= MIN_CFL,
        "numerics.cfl",
        n.cfl,
        f"must be at least {MIN_CFL:g}: the steps grow as 1/cfl, and a smaller one takes more "
        f"than {0.5 / MIN_CFL:.0f} times the steps of the default 0.5",
    )
    _require(
        n.h_eps >= MIN_H_EPS,
        "numerics.h_eps",
        n.h_eps,
        f"must be at least {MIN_H_EPS:g} m: velocities divide by h_eps^4, which below that "
        "is 0 in f32 and gives NaN in dry cells",
    )
    _require(
        n.h_eps < n.h_min,
        "numerics.h_eps",
        n.h_eps,
        f"must be smaller than numerics.h_min={n.h_min!r}",
    )
    _require(
        n.h_min < flow.h0,
        "numerics.h_min",
        n.h_min,
        f"must be smaller than flow.h0={flow.h0!r} (else the reference flow counts as empty)",
    )
    return n


def _check_friction_scheme(n: NumericsConfig, effects: EffectsConfig) -> None:
    """The regularised friction (an explicit source u / max(|u|, u_eps)) with a law: refused
    under RKC, a note under the SSP steppers (the split stepper refuses friction itself).

    RKC's inner stages are not positivity preserving: a front that the regularisation keeps
    creeping at about u_eps thins through h_min within a step, its fluxes switch off between
    stages, a stage empties the dry cell ahead below zero and the limiter's clip creates mass.
    Measured: a Coulomb block at rest on a 21 degree slope (mu = 0.47, dam-break scene, 300
    cells, RKC) broke the mass balance by 1.1e-6 at t = 0.91 s, where the projected scheme
    brings it to rest exactly (tests/test_friction_combinations.py). Under SSP steppers the
    combination is stable and conservative, but material held by friction keeps creeping."""
    if n.friction_scheme != "regularised" or effects.friction == "none":
        return
    _require(
        n.stepper != "rkc",
        "numerics.friction_scheme",
        n.friction_scheme,
        "with numerics.stepper = 'rkc' the regularised friction can create mass at fronts "
        "that creep through h_min: use friction_scheme = 'projected' (brings material to rest "
        "exactly), or an SSP stepper such as numerics.stepper = 'ssprk3'",
    )
    from .log import note

    note(
        f"numerics.friction_scheme='regularised': material that friction should hold creeps at "
        f"up to numerics.u_eps={n.u_eps:g} m/s; friction_scheme = 'projected' brings it to rest"
    )


def _check_split(n: NumericsConfig, flow: FlowConfig, effects: EffectsConfig) -> None:
    """What the split stepper needs (tiseg.numerics.split): no stiff terms, which its single
    explicit sweep per direction cannot take. (Any step rule is stable with it: "max" is
    each sweep's own Courant number, "sum" and "local" give shorter steps.)"""
    why = f"numerics.stepper={n.stepper!r} (dimensionally split sweeps) has no stiff terms"
    _require(
        not (effects.viscosity and flow.nu > 0.0),
        "effects.viscosity",
        effects.viscosity,
        f"{why}: switch the viscosity off (or flow.nu = 0), or use numerics.stepper = 'rkc'",
    )
    _require(
        effects.friction == "none",
        "effects.friction",
        effects.friction,
        f"{why}: use friction = 'none', or an SSP stepper such as numerics.stepper = "
        "'ssprk4_2' (or 'rkc')",
    )
    _require(
        not effects.segregation or n.phi_flux == "upwind",
        "numerics.phi_flux",
        n.phi_flux,
        f"numerics.stepper={n.stepper!r} keeps 0 <= phi <= 1 by scaling each face's fluxes by "
        "the factor of the cell the mass leaves, which needs the h phi flux to run with the "
        "mass flux: use phi_flux = 'upwind' with segregation",
    )


def _interval_count(key: str, interval: float, t_end: float, what: str) -> int:
    """How many multiples of ``interval`` lie in (0, t_end]; an InputError past
    MAX_OUTPUT_TIMES. An interval so short that there would be more than that many is a typo
    (1e-300 for 1e-3), and its multiples could not all be told apart in the output's times;
    t_end / interval is compared as a float first, as it may overflow."""
    ratio = t_end / interval * (1 + 1e-12)
    _require(
        ratio < MAX_OUTPUT_TIMES + 1,
        key,
        interval,
        f"gives {f'{ratio:.4g}' if math.isfinite(ratio) else 'over 1e308'} {what} up to "
        f"t_end={t_end!r}; at most {MAX_OUTPUT_TIMES} allowed (an interval of at least "
        f"{t_end / MAX_OUTPUT_TIMES:.3g} s)",
    )
    return math.floor(ratio)


def _read_output(t: "_Table", t_end: float) -> OutputConfig:
    interval = t.number("interval", None, positive=True)
    times = tuple(t.number_list("times", ()))
    for i, v in enumerate(times):
        _require(v >= 0.0, f"output.times[{i}]", v, "output times must be >= 0")
    late = [v for v in times if v > t_end * (1 + 1e-12)]
    if late:
        # one override (time.t_end) shortens a run: its later snapshots go, with a note
        from .log import note

        note(
            f"output.times {', '.join(f'{v:g}' for v in late)} lie past time.t_end="
            f"{t_end:g} s and are dropped"
        )
        times = tuple(v for v in times if v <= t_end * (1 + 1e-12))
    checkpoint = t.number("checkpoint_interval", None, positive=True)
    if checkpoint is not None:
        _interval_count("output.checkpoint_interval", checkpoint, t_end, "checkpoint times")
    # (time, priority): explicit times, 0 and t_end win over a nearby multiple of the interval
    cands = [(0.0, 0), (t_end, 0)] + [(min(v, t_end), 0) for v in times]
    if interval is not None:
        n = _interval_count("output.interval", interval, t_end, "snapshots")
        # %.12g turns 19 * 0.1 = 1.9000000000000001 into 1.9
        cands += [(min(float(f"{i * interval:.12g}"), t_end), 1) for i in range(n + 1)]
    cands.sort()
    tol = 1e-9 * t_end
    merged: list[tuple[float, int]] = []
    for tv, pr in cands:
        if merged and tv - merged[-1][0] <= tol:
            if pr < merged[-1][1]:
                merged[-1] = (tv, pr)
            continue
        merged.append((tv, pr))
    precision = (
        t.choice("precision", OUTPUT_PRECISIONS, aliases={"f64": "f8", "f32": "f4"})
        if t.has("precision")
        else None
    )
    digits = t.integer("significant_digits", lo=1) if t.has("significant_digits") else None
    _require(
        digits is None or digits <= 15,
        "output.significant_digits",
        digits,
        "at most 15 (an f8 holds about 16 decimal digits)",
    )
    return OutputConfig(
        interval=interval,
        times=times,
        checkpoint_interval=checkpoint,
        output_times=tuple(tv for tv, _ in merged),
        precision=precision,
        significant_digits=digits,
    )


# =================================================================================================
# Typed access to one TOML table
# =================================================================================================
class _Table:
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

    def get(self, key: str, default=_MISSING):
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            raise InputError(f"{self.full(key)} is required")
        return default

    def table(self, key: str, allowed: Iterable[str] | None = None) -> "_Table":
        v = self.data.get(key, {})
        full = self.full(key)
        if not isinstance(v, Mapping):
            raise InputError(f"{full}={_show(v)}: expected a table ([{full}]), got {_type_name(v)}")
        return _Table(v, full, SECTION_KEYS[key] if allowed is None else allowed)

    def string(self, key: str, default=_MISSING) -> str:
        v = self.get(key, default)
        if not isinstance(v, str):
            raise InputError(f"{self.full(key)}={_show(v)}: expected a string, got {_type_name(v)}")
        return v

    def boolean(self, key: str, default=_MISSING) -> bool:
        v = self.get(key, default)
        if not isinstance(v, bool):
            raise InputError(
                f"{self.full(key)}={_show(v)}: expected true or false, got {_type_name(v)}"
            )
        return v

    def choice(
        self,
        key: str,
        choices: tuple[str, ...],
        default=_MISSING,
        aliases: Mapping[str, str] | None = None,
    ) -> str:
        v = self.get(key, default)
        full = self.full(key)
        if not isinstance(v, str):
            raise InputError(
                f"{full}={_show(v)}: expected a string, one of "
                f"{', '.join(map(repr, choices))}; got {_type_name(v)}"
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
        default=_MISSING,
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
            raise InputError(f"{full}={_show(v)}: expected a number, got {_type_name(v)}")
        _check_underflow(full, v)
        f = float(v)
        if math.isnan(f) or (math.isinf(f) and not (allow_inf and f > 0)):
            raise InputError(f"{full}={_show(v)}: must be a finite number")
        if positive and not f > 0:
            raise InputError(f"{full}={_show(v)}: must be positive (> 0)")
        if nonneg and not f >= 0:
            raise InputError(f"{full}={_show(v)}: must not be negative")
        if lo is not None and hi is not None and not lo <= f <= hi:
            raise InputError(f"{full}={_show(v)}: must lie in [{lo:g}, {hi:g}]")
        if lo is not None and not f >= lo:
            raise InputError(f"{full}={_show(v)}: must be >= {lo:g}")
        if hi is not None and not f <= hi:
            raise InputError(f"{full}={_show(v)}: must be <= {hi:g}")
        return f

    def integer(self, key: str, default=_MISSING, *, lo=None) -> int:
        v = self.get(key, default)
        full = self.full(key)
        if isinstance(v, bool) or not isinstance(v, numbers.Integral):
            raise InputError(f"{full}={_show(v)}: expected an integer, got {_type_name(v)}")
        i = int(v)
        if lo is not None and i < lo:
            raise InputError(f"{full}={i}: must be an integer >= {lo}")
        return i

    def number_list(self, key: str, default=_MISSING) -> list[float]:
        v = self.get(key, default)
        full = self.full(key)
        if not isinstance(v, (list, tuple)):
            raise InputError(
                f"{full}={_show(v)}: expected an array of numbers such as "
                f"[1.0, 2.5], got {_type_name(v)}"
            )
        out = []
        for i, x in enumerate(v):
            if isinstance(x, bool) or not isinstance(x, numbers.Real) or not math.isfinite(x):
                raise InputError(
                    f"{full}[{i}]={_show(x)}: expected a finite number, got {_type_name(x)}"
                )
            _check_underflow(f"{full}[{i}]", x)
            out.append(float(x))
        return out


# =================================================================================================
# Small helpers
# =================================================================================================
_KEY_PART = re.compile(r"^[A-Za-z0-9_-]+$")


def _check_dotted_key(key, context) -> None:
    if not isinstance(key, str) or not key or not all(_KEY_PART.match(p) for p in key.split(".")):
        raise InputError(
            f"override {context!r}: the key {key!r} must be dotted names such as "
            "'flow.h0' or 'material.small.zeta1_deg'"
        )


def _apply_overrides(data: dict, overrides) -> None:
    """Apply ``section.key`` overrides to the raw scene dict in place (before validation)."""
    if overrides is None:
        return
    if isinstance(overrides, Mapping):
        items = []
        for key, value in overrides.items():
            _check_dotted_key(key, key)
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
            f"got {_type_name(overrides)}"
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
                    f"override {key!r}: {'.'.join(parts[: i + 1])} is "
                    f"{_type_name(nxt)}, not a table"
                )
            node = nxt
        if value is None:  # dict overrides only: remove the key
            node.pop(parts[-1], None)
        else:
            node[parts[-1]] = _deep_copy(value, key, len(parts))


class _Underflow(float):
    """A number written non-zero whose double is 0.0 or subnormal (1e-400, 1e-310), as TOML
    reads it. It keeps its text, so that the key reading it refuses it by name: taken as it is,
    flow.nu = 1e-400 would be 0 and switch the viscosity off without a word."""

    text: str

    def __new__(cls, value: float, text: str):
        obj = super().__new__(cls, value)
        obj.text = text
        return obj


def _toml_float(text: str) -> float:
    """tomllib's parse_float: the float of a TOML literal, an :class:`_Underflow` when a
    non-zero literal (a digit 1-9 before its exponent) does not survive as a normal double."""
    v = float(text)
    if not math.isfinite(v) or abs(v) >= sys.float_info.min:
        return v
    if v == 0.0 and not re.search(r"[1-9]", re.split(r"[eE]", text)[0]):
        return v  # written as zero: 0.0, -0e5
    return _Underflow(v, text)


def _check_underflow(key: str, v) -> None:
    if isinstance(v, _Underflow):
        raise InputError(
            f"{key}={v.text}: smaller than the smallest normal double "
            f"({sys.float_info.min:.3g}), it would be read as {float(v)!r}; write 0 for zero"
        )


def _deep_copy(v, where: str = "", depth: int = 0):
    """A copy of nested tables and arrays, refused past MAX_NESTING levels (which the
    recursion would otherwise meet as a RecursionError traceback); ``where``: the key path."""
    if depth > MAX_NESTING:
        raise InputError(
            f"{where if len(where) <= 60 else where[:57] + '...'}: tables or arrays nest more than {MAX_NESTING} levels deep "
            "(a scene needs at most 3, as in material.small.zeta1_deg)"
        )
    if isinstance(v, Mapping):
        return {
            k: _deep_copy(x, f"{where}.{k}" if where else str(k), depth + 1) for k, x in v.items()
        }
    if isinstance(v, (list, tuple)):
        return [_deep_copy(x, f"{where}[{i}]", depth + 1) for i, x in enumerate(v)]
    return v


def _require(cond: bool, key: str, value, rule: str) -> None:
    if not cond:
        raise InputError(f"{key}={_show(value)}: {rule}")


def _show(v) -> str:
    s = repr(v)
    return s if len(s) <= 60 else s[:57] + "..."


def _type_name(v) -> str:
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


def _close(a: float, b: float, rel: float = 1e-9) -> bool:
    return abs(a - b) <= rel * max(abs(a), abs(b))


def _near_integer(x: float | None, rel: float = 1e-6) -> bool:
    return x is not None and round(x) >= 1 and abs(x - round(x)) <= rel * max(1.0, abs(x))


__all__ = [
    "Scene",
    "FlowConfig",
    "EffectsConfig",
    "DomainConfig",
    "BoundaryConfig",
    "InflowConfig",
    "InitialConfig",
    "NumericsConfig",
    "TimeConfig",
    "OutputConfig",
    "load_scene",
    "scene_from_text",
    "scene_from_dict",
    "scene_to_dict",
    "parse_override",
    "list_builtin_scenes",
    "SCENE_DIR",
    "InputError",
]
