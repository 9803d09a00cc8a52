"""Reading each section: the generic read of its declared keys, then its cross-key rules.

A key's own type, range and choices are checked by the generic reader
(`tiseg.setup.schema.read_section`) from its declaration; what is left here are the rules
that tie keys together, each an explicit check with a one-line message naming every key it
involves: a steady flow that defines u0 (4.3), a grid sized by a resolution or by perturbation
wavelengths, periodic sides in pairs, an inflow perturbation that keeps phi in [0, 1], the keys
of each initial kind, the stepper's needs, the output times.
"""

from __future__ import annotations

import math
import re
from types import SimpleNamespace

from ..errors import InputError
from ..log import note
from ..model.material import Material, Species
from ..solver.numerics.config import STEP_RULES, SPLIT_CFL, is_split, noise_modes
from ..model.physics.friction import FRICTION_LAWS as LAWS, layer_thresholds
from ..model.physics.sources import AUX_FIELDS, SOURCES, components
from ..model.steady import steady_state
from .schema import DECLARED, field_named, key_fields, key_of, read_key, read_section, read_tables
from .initial import INITIAL_KINDS
from .sections import (
    SPECIES_KEYS,
    BoundaryConfig,
    DomainConfig,
    EffectsConfig,
    FlowConfig,
    GaugeKeys,
    InflowConfig,
    InitialConfig,
    NumericsConfig,
    OutputConfig,
    SpeciesKeys,
    effects_fields,
    initial_keys,
    law_constants,
    material_fields,
)
from .table import Table, close, near_integer, require, show

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
MAX_OUTPUT_TIMES = 1_000_000  # snapshots or checkpoint times: guards against interval = 1e-12


# ---- material, effects, flow --------------------------------------------------------------------
def read_material(t: Table) -> Material:
    """The Material of the section: its keys (the laws' constants among them), each species'
    table with that species' Table 1 values as defaults; Material checks the rest."""
    base = Material()
    kw: dict = {}
    for f in material_fields():
        if f.name not in ("small", "large"):
            kw[f.name] = read_key(t, f)
            continue
        st = t.table(f.name, SPECIES_KEYS)
        sp0: Species = getattr(base, f.name)
        kw[f.name] = Species(
            **{
                g.name: read_key(st, g, getattr(sp0, g.name) if g.name != "zeta3_deg" else None)
                for g in key_fields(SpeciesKeys)
            }
        )
    return Material(**kw)  # checks the remaining ranges, naming material.<key>


def read_effects(t: Table) -> EffectsConfig:
    """The switches and the values of the constants kept with the effects: the laws' always,
    a source term's (and those of the fields it reads) only while ``effects.sources`` names
    it; given for a term that is off, a constant is an error (it would do nothing)."""
    own = {f.name for f in key_fields(EffectsConfig)}
    laws = {f.name for f in law_constants("effects")}
    fields = {f.name: f for f in effects_fields()}
    values = {n: read_key(t, f) for n, f in fields.items() if n in own or n in laws}
    on = {c.name for comp in components(values["sources"]) for c in comp.constants}
    for name in fields:
        if name in own or name in laws:
            continue
        if name in on:
            values[name] = read_key(t, fields[name])
        elif t.has(name):
            owners = [
                c.name
                for c in (*SOURCES.values(), *AUX_FIELDS.values())
                if any(k.name == name for k in c.constants)
            ]
            raise InputError(
                f"effects.{name}={show(t.get(name))}: a constant of {' and '.join(map(repr, owners))}, "
                "which no term of effects.sources uses; add the term to effects.sources or "
                "remove the key"
            )
    constants = tuple((k, v) for k, v in values.items() if k not in own)
    return EffectsConfig(**{k: v for k, v in values.items() if k in own}, constants=constants)


def read_flow(t: Table, material: Material, effects: EffectsConfig) -> FlowConfig:
    """h0, phi0, nu, and u0: derived from the steady uniform flow (4.3), (4.9) for a law of
    section 4 (given u0 is then an error), else given or None."""
    v = read_section(FlowConfig, t, skip=("u0",))
    h0, phi0, nu = v["h0"], v["phi0"], v["nu"]
    # (6.2)'s coefficient is 0.01 m^(3/2)/s in the paper; beyond MAX_NU the viscous stiffness
    # nu sqrt(h) / dx^2 leaves no representable step on any grid (and overflows in the kernels)
    require(
        nu <= MAX_NU,
        "flow.nu",
        nu,
        f"must be at most {MAX_NU:g} m^(3/2)/s (the paper "
        "uses 0.01); a larger viscosity leaves no time step that can advance",
    )
    law = effects.friction
    if LAWS[law].steady:
        if t.has("u0"):
            raise InputError(
                f"flow.u0={show(t.get('u0'))}: with effects.friction={law!r} u0 is "
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
        if LAWS[law].hysteresis and st.F < material.beta_star:
            # (4.3) is the steady flow of the dynamic regime only
            why = (
                f"flow.h0={h0!r}, flow.phi0={phi0!r}: the steady flow (4.3) has F = {st.F:.3g} "
                f"< material.beta_star = {material.beta_star:g}, outside the dynamic regime of "
                f"effects.friction={law!r}, which defines u0 only there (thicken flow.h0)"
            )
            return FlowConfig(h0=h0, phi0=phi0, nu=nu, no_steady=why)
        return FlowConfig(h0=h0, phi0=phi0, nu=nu, u0=st.u0, F=st.F)
    u0 = read_key(t, field_named(FlowConfig, "u0"))
    F = None if u0 is None else u0 / math.sqrt(material.g * h0 * material.cos_zeta)
    return FlowConfig(h0=h0, phi0=phi0, nu=nu, u0=u0, F=F)


# ---- domain, boundary ---------------------------------------------------------------------------
def _dom(t: Table, name: str, default=DECLARED):
    return read_key(t, field_named(DomainConfig, name), default)


def read_domain(t: Table, ini: Table, kind: str, flow: FlowConfig):
    """Domain size and grid; also returns the number of downslope perturbation wavelengths of a
    uniform initial state (None for other kinds), since Lx and it determine each other."""
    k = wavelengths = None
    if kind == "uniform":
        k = _ini(ini, "k")
        wavelengths = _ini(ini, "wavelengths")
    resolution = _dom(t, "resolution")
    if t.has("Lx"):
        Lx = _dom(t, "Lx")
        if k:
            implied = Lx * k / (2.0 * math.pi * flow.h0)
            if wavelengths is not None and not close(implied, wavelengths):
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
        ny = _dom(t, "ny")
    elif resolution is not None and t.has("Ly"):
        ny = _cells_of(_dom(t, "Ly"), resolution, "domain.Ly")
        # only an explicit ny = 1 makes a 1D run; a derived count must resolve the width
        require(
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
        _dom(t, "Ly", None)  # still type-checked when given
        Ly = Lx / nx
    else:
        if not t.has("Ly"):
            raise InputError(f"domain.Ly is required for a 2D run (domain.ny={ny})")
        Ly = _dom(t, "Ly")
        if t.has("ny") and resolution is not None:
            _grid_count(t, "ny", "Ly", Ly, resolution)  # consistency check only
        require(
            ny >= MIN_CELLS,
            "domain.ny",
            ny,
            f"a 2D run needs at least {MIN_CELLS} cells across the slope (or ny = 1 for 1D)",
        )
    require(nx >= MIN_CELLS, "domain.nx", nx, f"needs at least {MIN_CELLS} cells")
    require(
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
    t: Table, key: str, length_key: str, length: float, resolution: float | None
) -> int:
    if resolution is not None:
        implied = _cells_of(length, resolution, f"domain.{length_key}")
        if t.has(key):
            n = _dom(t, key)
            if n != implied:
                raise InputError(
                    f"domain.{key}={n} disagrees with domain.resolution={resolution!r} x "
                    f"domain.{length_key}={length!r} = {implied} cells; change "
                    f"domain.resolution instead, or give domain.{key} without a resolution"
                )
            return n
        require(
            implied >= 1,
            f"domain.{key}",
            implied,
            f"domain.resolution={resolution!r} x domain.{length_key}={length!r} gives no cells",
        )
        return implied
    if not t.has(key):
        raise InputError(f"domain.{key} or domain.resolution is required (cells in {length_key})")
    return _dom(t, key)


def read_boundary(t: Table, domain: DomainConfig) -> BoundaryConfig:
    sides = {}
    for f in key_fields(BoundaryConfig):
        v = read_key(t, f)
        if v == "inflow" and f.name != "x_lo":
            raise InputError(
                f"boundary.{f.name}='inflow': an inflow is only supported at x_lo "
                "(the top of the slope)"
            )
        sides[f.name] = v
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


# ---- inflow -------------------------------------------------------------------------------------
def read_inflow(
    t: Table, given: bool, boundary: BoundaryConfig, domain: DomainConfig, flow: FlowConfig
) -> InflowConfig | None:
    if boundary.x_lo != "inflow":
        if given:
            raise InputError(
                f"[inflow] is given but boundary.x_lo={boundary.x_lo!r}; set "
                "boundary.x_lo = 'inflow' or remove the [inflow] section"
            )
        return None
    if not t.has("u") and flow.u0 is None:
        if t.has("h"):
            read_key(t, field_named(InflowConfig, "h"))  # a bad h is named first, as before
        if flow.no_steady:
            raise InputError(
                f"{flow.no_steady}; the inflow velocity defaults to that u0, so give inflow.u"
            )
        raise InputError(
            "inflow.u is required: without a 'pouliquen-mixture' or 'pouliquen-extended' "
            "friction there is no derived steady velocity (give inflow.u or flow.u0)"
        )
    v = read_section(InflowConfig, t, {"h": flow.h0, "u": flow.u0, "phi": flow.phi0})
    phi, delta, noise, modes = v["phi"], v["perturbation"], v["noise"], v["modes"]
    if v["stop_time"] is not None and math.isinf(v["stop_time"]):
        v["stop_time"] = None  # inf = never stops = continuous inflow
    if not (0.0 <= phi - abs(delta) and phi + abs(delta) <= 1.0):
        raise InputError(
            f"inflow.perturbation={delta!r}: phi = inflow.phi={phi!r} +- "
            f"{abs(delta)!r} leaves [0, 1]; use a smaller perturbation (or 0)"
        )
    if v["seed"] >= 2**63:
        raise InputError(f"inflow.seed={v['seed']}: must be below 2**63")
    if v["forcing_amplitude"] >= 1.0:
        raise InputError(
            f"inflow.forcing_amplitude={v['forcing_amplitude']!r}: the inflow thickness "
            "h (1 + a sin(2 pi f t)) would reach 0; use an amplitude below 1 (0.05 is typical)"
        )
    if v["forcing_amplitude"] > 0.0 and v["forcing_frequency"] == 0.0:
        raise InputError(
            f"inflow.forcing_amplitude={v['forcing_amplitude']!r} needs "
            "inflow.forcing_frequency > 0 [Hz] (a modulation at 0 Hz does nothing)"
        )
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
    _check_inlet(v["width"], v["y0"], domain)
    return InflowConfig(**v)


def _check_inlet(width, y0, domain: DomainConfig) -> None:
    """A localised inlet (inflow.width, inflow.y0) lies inside [0, Ly] and covers a cell."""
    if width is None:
        if y0 is not None:
            raise InputError(f"inflow.y0={y0!r} needs inflow.width (the inlet's width) [m]")
        return
    if domain.is_1d:
        raise InputError(f"inflow.width={width!r}: a localised inlet needs a 2D domain (ny > 1)")
    c = domain.Ly / 2 if y0 is None else y0
    if c - width / 2 < -1e-9 * domain.Ly or c + width / 2 > domain.Ly * (1 + 1e-9):
        raise InputError(
            f"inflow.width={width!r}, inflow.y0={c!r}: the inlet [{c - width / 2:.4g}, "
            f"{c + width / 2:.4g}] m leaves the domain's width [0, {domain.Ly!r}] m"
        )
    if round((c + width / 2) / domain.dy) - round((c - width / 2) / domain.dy) < 1:
        raise InputError(
            f"inflow.width={width!r}: the inlet covers no cell of dy={domain.dy:.4g} m; "
            "widen it or refine domain.resolution"
        )


# ---- initial state ------------------------------------------------------------------------------
def initial_kind(t: Table) -> str:
    """initial.kind, with the keys of other kinds refused (they would go unused)."""
    kind = read_key(t, field_named(InitialConfig, "kind"))
    t.only(initial_keys()[kind], f"initial.kind={kind!r}")
    return kind


def _ini(t: Table, name: str, ctx=None):
    """One initial-state key with the default its kind reads (see ``_ini`` of the sections)."""
    f = field_named(InitialConfig, name)
    d = key_of(f).read_default
    return read_key(t, f, d(ctx) if callable(d) else d)


def read_initial(
    t: Table,
    kind: str,
    wavelengths: float | None,
    domain: DomainConfig,
    boundary: BoundaryConfig,
    flow: FlowConfig,
    effects: EffectsConfig,
    material: Material | None = None,
) -> InitialConfig:
    """The keys of ``kind``, read as declared (with the defaults that kind reads), then the
    rules that tie them to the domain and the flow."""
    if kind == "empty":
        return InitialConfig(kind="empty")
    if kind == "uniform" and flow.no_steady:
        raise InputError(f"initial.kind='uniform' needs the steady uniform flow: {flow.no_steady}")
    if kind == "uniform" and flow.u0 is None:
        raise InputError(
            "initial.kind='uniform' needs the steady velocity u0: give flow.u0 "
            f"(effects.friction={effects.friction!r} does not define one)"
        )
    require(
        kind != "channel" or not domain.is_1d,
        "initial.kind",
        kind,
        "a channel lies across the slope: it needs a 2D domain (domain.ny > 1)",
    )
    ctx = SimpleNamespace(flow=flow, domain=domain)
    # wavelengths was read with the domain, which it sizes
    names = [n for n in initial_keys()[kind] if n not in ("kind", "wavelengths")]
    v = {n: _ini(t, n, ctx) for n in names}
    if kind == "uniform":
        _check_uniform(v, wavelengths, domain, boundary, flow, effects)
        v["wavelengths"] = wavelengths
    elif kind == "dam-break":
        require(
            0.0 < v["x0"] < domain.Lx,
            "initial.x0",
            v["x0"],
            f"must lie inside (0, Lx={domain.Lx!r})",
        )
        require(
            v["h_left"] > 0 or v["h_right"] > 0,
            "initial.h_left",
            v["h_left"],
            "h_left and h_right cannot both be 0 (nothing would move)",
        )
    elif kind == "channel":
        require(
            v["width"] < domain.Ly,
            "initial.width",
            v["width"],
            f"must be narrower than the chute, Ly={domain.Ly!r}",
        )
    elif kind == "layer":
        _check_layer(v["layer_h"], v["phi"], effects, material or Material())
    elif kind == "cap":
        x0, a = v["x0"], v["half_width"]
        require(
            a <= x0 <= domain.Lx - a,
            "initial.x0",
            x0,
            f"the cap [x0 - half_width, x0 + half_width] must lie in [0, Lx={domain.Lx!r}]",
        )
    elif kind == "release":  # a block of material at rest
        x0, x1, y0, y1 = v["x0"], v["x1"], v["y0"], v["y1"]
        require(x0 >= 0.0, "initial.x0", t.get("x0"), "must be >= 0")
        require(
            x0 < x1 <= domain.Lx,
            "initial.x1",
            x1,
            f"need initial.x0={x0!r} < x1 <= Lx={domain.Lx!r}",
        )
        require(
            y0 < y1 <= domain.Ly * (1 + 1e-12),
            "initial.y1",
            y1,
            f"need initial.y0={y0!r} < y1 <= Ly={domain.Ly!r}",
        )
    elif INITIAL_KINDS[kind].check is not None:  # a kind registered by user code
        INITIAL_KINDS[kind].check(v, domain)
    return InitialConfig(kind=kind, **v)


def _check_layer(layer_h: float, phi: float, effects: EffectsConfig, material: Material) -> None:
    """A static layer is held at rest only by the extended law, and only thinner than
    h_start; thinner than h_stop it is held too, but thinner than any deposit a flow leaves."""
    if effects.friction != "pouliquen-extended":
        note(
            f"initial.kind='layer' with effects.friction={effects.friction!r}: only the "
            "extended law ('pouliquen-extended') holds a layer at rest below h_start and lets a "
            "wave set it moving (hysteresis); under this law it flows unless friction holds it"
        )
        return
    h_stop, h_start = layer_thresholds(material, phi)
    require(
        layer_h < h_start,
        "initial.layer_h",
        layer_h,
        f"must be thinner than h_start={h_start:.4g} m at this slope, or the layer is not "
        "held at rest and starts everywhere at once",
    )
    if layer_h <= h_stop:
        note(
            f"initial.layer_h={layer_h:g} is not above h_stop={h_stop:.4g} m: it is held at "
            "rest, but a flow over it deposits h_stop, so waves thicken it as they pass"
        )


def _check_uniform(v, wavelengths, domain, boundary, flow, effects) -> None:
    amplitude, k, ky, mode = v["amplitude"], v["k"], v["ky"], v["mode"]
    require(
        amplitude < 1.0,
        "initial.amplitude",
        amplitude,
        "relative amplitude must be < 1 (h must stay positive)",
    )
    if domain.is_1d and ky != 0.0:
        raise InputError(
            f"initial.ky={ky!r}: a 1D run (domain.ny = 1) has no cross-slope wavenumber; use 0"
        )
    if amplitude > 0 and mode not in ("noise", "h-noise") and k == 0.0 and ky == 0.0:
        raise InputError(
            f"initial.amplitude={amplitude!r} with initial.mode={mode!r} needs "
            "initial.k > 0 or initial.ky > 0"
        )
    if mode in ("phi", "noise") and not effects.segregation:
        raise InputError(
            f"initial.mode={mode!r} perturbs the concentration, but "
            "effects.segregation = false has no phi field"
            + (' (initial.mode = "h-noise" perturbs the thickness)' if mode == "noise" else "")
        )
    if k and boundary.x_lo == "periodic" and not near_integer(wavelengths):
        raise InputError(
            f"initial.wavelengths={wavelengths:.6g}: domain.Lx={domain.Lx!r} holds that many "
            f"wavelengths of initial.k={k!r}, but a periodic domain needs a whole number "
            "(set initial.wavelengths to an integer and leave domain.Lx out)"
        )
    if ky and boundary.y_lo == "periodic":
        ny_waves = domain.Ly * ky / (2.0 * math.pi * flow.h0)
        if not near_integer(ny_waves):
            raise InputError(
                f"initial.ky={ky!r}: domain.Ly={domain.Ly!r} holds {ny_waves:.6g} wavelengths; "
                "a periodic domain needs a whole number (ky = 2 pi h0 n / Ly)"
            )


# ---- numerics -----------------------------------------------------------------------------------
def read_numerics(t: Table, flow: FlowConfig, is_1d: bool, effects: EffectsConfig):
    """The numerics; numerics.cfl defaults to the positivity bound of the step rule (or the
    split sweeps' SPLIT_CFL), and the stepper's needs are checked."""
    stepper = read_key(t, field_named(NumericsConfig, "stepper"))
    rule = read_key(t, field_named(NumericsConfig, "step_rule"))
    split = is_split(stepper)
    n = NumericsConfig(
        **read_section(NumericsConfig, t, {"cfl": SPLIT_CFL if split else STEP_RULES[rule]})
    )
    if split:
        _check_split(n, flow, effects)
        if rule != "max" and not is_1d:
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
            note(
                f"numerics.cfl={n.cfl:g} is above the positivity bound {bound:g} of step_rule "
                f"{rule!r}{' in 1D' if is_1d else ''}: h may turn negative at dry fronts, where "
                f"the stage limiter clips it and mass is then not conserved exactly; set "
                f"numerics.cfl={bound:g} for stepper {n.stepper!r} (a split stepper's Courant "
                "number per sweep, as in the fingers scene, does not carry over)"
            )
    require(
        n.cfl >= MIN_CFL,
        "numerics.cfl",
        n.cfl,
        f"must be at least {MIN_CFL:g}: the steps grow as 1/cfl, and a smaller one takes more "
        f"than {0.5 / MIN_CFL:.0f} times the steps of the default 0.5",
    )
    require(
        n.h_eps >= MIN_H_EPS,
        "numerics.h_eps",
        n.h_eps,
        f"must be at least {MIN_H_EPS:g} m: velocities divide by h_eps^4, which below that "
        "is 0 in f32 and gives NaN in dry cells",
    )
    require(
        n.h_eps < n.h_min,
        "numerics.h_eps",
        n.h_eps,
        f"must be smaller than numerics.h_min={n.h_min!r}",
    )
    require(
        n.h_min < flow.h0,
        "numerics.h_min",
        n.h_min,
        f"must be smaller than flow.h0={flow.h0!r} (else the reference flow counts as empty)",
    )
    return n


def _check_friction_scheme(n: NumericsConfig, effects: EffectsConfig) -> None:
    """The regularised friction (an explicit source u / max(|u|, u_eps)) with a law: refused
    under RKC, a note under the SSP steppers (the split stepper refuses it itself).

    RKC's inner stages are not positivity preserving: a front that the regularisation keeps
    creeping at about u_eps thins through h_min within a step, its fluxes switch off between
    stages, a stage empties the dry cell ahead below zero and the limiter's clip creates mass.
    Measured: a Coulomb block at rest on a 21 degree slope (mu = 0.47, dam-break scene, 300
    cells, RKC) broke the mass balance by 1.1e-6 at t = 0.91 s, where the projected scheme
    brings it to rest exactly (tests/test_friction_combinations.py). Under SSP steppers the
    combination is stable and conservative, but material held by friction keeps creeping."""
    if n.friction_scheme != "regularised" or effects.friction == "none":
        return
    require(
        n.stepper != "rkc",
        "numerics.friction_scheme",
        n.friction_scheme,
        "with numerics.stepper = 'rkc' the regularised friction can create mass at fronts "
        "that creep through h_min: use friction_scheme = 'projected' (brings material to rest "
        "exactly), or an SSP stepper such as numerics.stepper = 'ssprk3'",
    )
    note(
        f"numerics.friction_scheme='regularised': material that friction should hold creeps at "
        f"up to numerics.u_eps={n.u_eps:g} m/s; friction_scheme = 'projected' brings it to rest"
    )


def _check_split(n: NumericsConfig, flow: FlowConfig, effects: EffectsConfig) -> None:
    """What the split stepper needs (tiseg.solver.numerics.split): friction only as the
    projection after the step's sub-steps (the regularised source is a stiff term that no
    sweep can take; the viscosity is a sub-step of its own, with RKC stages). (Any step rule
    is stable with it: "max" is each sweep's own Courant number, "sum" and "local" give
    shorter steps.)"""
    require(
        effects.friction == "none" or n.friction_scheme == "projected",
        "numerics.friction_scheme",
        n.friction_scheme,
        f"numerics.stepper={n.stepper!r} applies friction only as the projection: use "
        "friction_scheme = 'projected', or an SSP stepper such as numerics.stepper = "
        "'ssprk4_2' for the regularised friction",
    )
    require(
        not effects.segregation or n.phi_flux == "upwind",
        "numerics.phi_flux",
        n.phi_flux,
        f"numerics.stepper={n.stepper!r} keeps 0 <= phi <= 1 by scaling each face's fluxes by "
        "the factor of the cell the mass leaves, which needs the h phi flux to run with the "
        "mass flux: use phi_flux = 'upwind' with segregation",
    )


# ---- output -------------------------------------------------------------------------------------
def _interval_count(key: str, interval: float, t_end: float, what: str) -> int:
    """How many multiples of ``interval`` lie in (0, t_end]; an InputError past
    MAX_OUTPUT_TIMES. An interval so short that there would be more than that many is a typo
    (1e-300 for 1e-3), and its multiples could not all be told apart in the output's times;
    t_end / interval is compared as a float first, as it may overflow."""
    ratio = t_end / interval * (1 + 1e-12)
    require(
        ratio < MAX_OUTPUT_TIMES + 1,
        key,
        interval,
        f"gives {f'{ratio:.4g}' if math.isfinite(ratio) else 'over 1e308'} {what} up to "
        f"t_end={t_end!r}; at most {MAX_OUTPUT_TIMES} allowed (an interval of at least "
        f"{t_end / MAX_OUTPUT_TIMES:.3g} s)",
    )
    return math.floor(ratio)


GAUGE_NAME = re.compile(r"[A-Za-z0-9_.-]{1,64}")


def read_gauges(t: Table, domain) -> tuple:
    """``[[output.gauges]]``: each point on the chute (x in [0, Lx], y in [0, Ly], y default
    Ly/2), each name distinct and fit for a CSV column (default g1, g2, ... by position)."""
    f = field_named(OutputConfig, "gauges")
    out, seen = [], set()
    for i, g in enumerate(read_tables(t, f)):
        where = f"output.gauges[{i}]"
        name = g["name"] if g["name"] is not None else f"g{i + 1}"
        require(
            GAUGE_NAME.fullmatch(name) is not None,
            f"{where}.name",
            name,
            "1 to 64 letters, digits, _ - or . (it names gauges.csv's columns)",
        )
        require(name not in seen, f"{where}.name", name, "another gauge has this name")
        seen.add(name)
        y = g["y"]
        if domain is not None:
            y = domain.Ly / 2 if y is None else y
            require(0.0 <= g["x"] <= domain.Lx, f"{where}.x", g["x"], f"in [0, Lx={domain.Lx:g}]")
            require(0.0 <= y <= domain.Ly, f"{where}.y", y, f"in [0, Ly={domain.Ly:g}]")
        out.append(GaugeKeys(x=g["x"], y=y, name=name))
    return tuple(out)


def read_output(t: Table, t_end: float, domain=None) -> OutputConfig:
    """The output keys, and the resolved snapshot times: 0, t_end, the given times up to t_end
    (later ones dropped with a note) and the multiples of the interval, merged where closer
    than 1e-9 t_end. The gauges (on the chute of ``domain``) with their defaults filled in."""
    v = read_section(OutputConfig, t)
    v["gauges"] = read_gauges(t, domain)
    interval, times, checkpoint = v["interval"], v["times"], v["checkpoint_interval"]
    for i, x in enumerate(times):
        require(x >= 0.0, f"output.times[{i}]", x, "output times must be >= 0")
    late = [x for x in times if x > t_end * (1 + 1e-12)]
    if late:
        # one override (time.t_end) shortens a run: its later snapshots go, with a note
        note(
            f"output.times {', '.join(f'{x:g}' for x in late)} lie past time.t_end="
            f"{t_end:g} s and are dropped"
        )
        times = tuple(x for x in times if x <= t_end * (1 + 1e-12))
    if checkpoint is not None:
        _interval_count("output.checkpoint_interval", checkpoint, t_end, "checkpoint times")
    # (time, priority): explicit times, 0 and t_end win over a nearby multiple of the interval
    cands = [(0.0, 0), (t_end, 0)] + [(min(x, t_end), 0) for x in times]
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
    digits = v["significant_digits"]
    require(
        digits is None or digits <= 15,
        "output.significant_digits",
        digits,
        "at most 15 (an f8 holds about 16 decimal digits)",
    )
    return OutputConfig(**{**v, "times": times}, output_times=tuple(tv for tv, _ in merged))
