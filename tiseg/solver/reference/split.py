"""NumPy twin of a sweep of the dimensionally split MUSCL-Hancock scheme
(`tiseg.solver.numerics.split`, whose docstring gives the steps), built from the pieces of the
reference operator (`tiseg.solver.reference.operator.ReferenceOperator`): ghost cells,
primitives, slopes, physical and numerical fluxes, source, viscous stresses and stage
limiter; and of the viscous sub-step of a split step with viscosity (`viscous_substep`)."""

from __future__ import annotations

import numpy as np

from ..numerics.boundaries import inlet_rows
from ..timestepping.rkc import rkc_coefficients
from .bed import eta_slopes, star_states
from .walls import FLUID, SOLID, WALL_HI, WALL_LO, face_kinds, faced
from .operator import SQRT2, ReferenceOperator


def split_primitives(ref: ReferenceOperator, q: np.ndarray) -> np.ndarray:
    """The primitives of a split scene (FiniteVolume.fast_primitive): the reference's
    desingularised ones computed as (hu) / h where h >= h_eps, which they equal up to
    rounding, and the desingularised formula below."""
    c, lay = ref.cfg, ref.lay
    h = np.maximum(q[lay.H], 0.0)
    h4 = h * h * h * h
    eps4 = c.h_eps**4
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(h4 >= eps4, 1.0 / np.where(h > 0, h, 1.0), SQRT2 * h / np.sqrt(h4 + eps4))
    return ref.primitives_of(q, h, lambda m: r * m)


def hancock_sweep(
    ref: ReferenceOperator,
    q: np.ndarray,
    t: float,
    dt: float,
    d: int,
    drain: bool = True,
    fallback: bool = True,
    limit: bool = True,
    start: np.ndarray | None = None,
    last: bool = True,
    hbar: np.ndarray | None = None,
) -> dict:
    """Advance q (nc, NX, NY), ghost cells included, by one sweep along d (0 = x, 1 = y) over
    dt from time t, in place, with the ghost cells at time t (an inflow's at t + dt/2). Returns what entered through the domain's
    faces along d over the sweep: {"mass": ..., "small_mass": ...} [m^3] (per unit of y
    spacing in 1D, as the operator's budget).

    ``drain``, ``fallback``, ``limit``: the draining-time scaling, the predictor's dry-edge
    fallback and the stage limiter, each switchable for tests that show what it prevents.
    With the projected friction: ``start``, the primitives of the step's initial state (its
    rest mask and speeds; by default q's own, as in a step's first sweep), and ``last``, the
    sweep closes the step and projects the friction of the whole step (`hancock_step`
    runs a step of sweeps) on the thickness the step's gravity acted on: the x sweep's
    trapezoidal mean, which an x sweep that does not close the step returns as ``"hbar"``
    for the y sweep that does (its ``hbar``)."""
    c, lay = ref.cfg, ref.lay
    axis = d + 1
    n = q.shape[axis]

    def sl(a, b):
        idx = [slice(None)] * q.ndim
        idx[axis] = slice(a, b)
        return tuple(idx)

    if start is None:
        ref.fill_ghosts(q, t)
        start = ref.rest_view(split_primitives(ref, q), t)
    # an inflow's ghost cells at mid-step (SplitSweeps.sweep)
    t = t + 0.5 * dt if c.bc[0] == "inflow" else t
    ref.fill_ghosts(q, t)
    w = split_primitives(ref, q)
    lam = dt / (c.dx if d == 0 else c.dy)
    s = ref.slopes(w, axis)
    wW, wE = w - 0.5 * s, w + 0.5 * s
    qW, qE = ref.conserved(wW), ref.conserved(wE)
    gcell = ref.gcell  # (a bend's gravity per column; None on a plane)
    shift = 0.5 * lam * (ref.flux(wE, d, gcell) - ref.flux(wW, d, gcell))
    keep = np.zeros(q.shape[1:], dtype=bool)  # edges left unevolved: an inflow's ghost cells
    if d == 0:
        # a wall's ghost cells mirror the source as they mirror the state
        sgn = np.ones(q.shape[1:])
        gx, nx = lay.gx, lay.nx
        lo, hi = c.bc[0], c.bc[1]
        inflow_on = lo == "inflow" and not t > c.inflow_stop
        if lo == "wall" or (lo == "inflow" and not inflow_on):
            sgn[:gx] = -1.0
        keep[:gx] = inflow_on
        if hi == "wall":
            sgn[gx + nx :] = -1.0
        src = ref.source(w)
        terms = ref.terms(w) if c.sources else None  # the scene's terms, at the sweep's start
        if terms is not None:
            src = src + terms
        shift = shift - 0.5 * dt * sgn[None] * src
    mom = lay.HU if d == 0 else lay.HV
    if ref.bed is not None:  # the bed at the edges and its pull over the half step
        es = eta_slopes(ref, w, ref.bed, axis, ref.solid)
        eta = w[0] + ref.bed
        bW, bE = eta - 0.5 * es - wW[0], eta + 0.5 * es - wE[0]
        inv = 1.0 / (c.dx if d == 0 else c.dy)
        gc = ref.gravity_part(gcell, 1)
        pull = 0.5 * dt * inv * (0.5 * gc * (wW[0] + wE[0]) * (bW - bE))
        shift = shift.copy()
        shift[mom] = shift[mom] - pull
    pW, pE = qW - shift, qE - shift
    bad = ((pW[0] < 0.0) | (pE[0] < 0.0))[None] & fallback  # the predictor would empty an edge
    bad = bad | keep[None]
    if d == 0 and ref.projected:
        # the half step's friction on the evolved edges, at the cell's speed
        spd = ref._magnitude(w)
        pW, pE = pW.copy(), pE.copy()
        project(ref, pW, 0.5 * dt, spd)
        project(ref, pE, 0.5 * dt, spd)
    eW = split_primitives(ref, np.where(bad, qW, pW))
    eE = split_primitives(ref, np.where(bad, qE, pE))
    # the face (m, m + 1) at index m; zero between films thinner than h_min at rest
    H = np.zeros_like(q)
    wl, wr = eE[sl(0, n - 1)], eW[sl(1, n)]
    if ref.projected:  # two cells at rest at the step's start meet with no velocity
        still = start[lay.HU] == 0
        if not lay.is_1d:
            still = still & (start[lay.HV] == 0)
        both = (still[sl(0, n - 1)[1:]] & still[sl(1, n)[1:]])[None]
        moving = np.zeros(lay.nc, dtype=bool)
        moving[lay.HU] = True
        if not lay.is_1d:
            moving[lay.HV] = True
        zero = both & moving[:, None, None]
        wl, wr = np.where(zero, 0.0, wl), np.where(zero, 0.0, wr)
    face_lo, face_hi = sl(0, n - 1)[1:], sl(1, n)[1:]
    kinds = np.zeros(wl.shape[1:], dtype=int)
    if ref.solid is not None:  # walls: the fluid side and its mirror
        kinds = face_kinds(ref.solid, axis)
        wl, wr = faced(lay, kinds, wl, wr, d)
    if ref.bed is not None:  # h* at the faces, and each side's pressure correction
        hl_e, hr_e = wl[0].copy(), wr[0].copy()
        bl, br = bE[face_lo], bW[face_hi]
        br = np.where(kinds == WALL_HI, bl, br)
        bl = np.where((kinds == WALL_LO) | (kinds == SOLID), br, bl)
        wl, wr, pl, pr = star_states(ref, wl, bl, wr, br, ref.face_gravity(axis))
    H[sl(0, n - 1)] = ref.numerical_flux(wl, wr, d, ref.face_gravity(axis))
    if ref.projected:  # the face rules of the step's rest mask (not at walls)
        Hf = H[sl(0, n - 1)].copy()
        ref.rest_faces(Hf, wl, wr, start, d, face_lo, face_hi)
        H[sl(0, n - 1)] = np.where((kinds == FLUID)[None], Hf, H[sl(0, n - 1)])
    h = w[0]
    dry = np.zeros(h.shape, dtype=bool)
    dry[face_lo] = ref.dry_faces(w, start, face_lo, face_hi) | (kinds == SOLID)
    H = np.where(dry[None], 0.0, H)
    if ref.bed is not None:  # a face without convective flux: each side's whole pressure
        half_g = 0.5 * ref.gravity_part(ref.face_gravity(axis), 1)
        pc = np.zeros((2,) + q.shape[1:])
        none = kinds == SOLID
        pc[(0,) + face_lo] = np.where(none, 0.0, np.where(dry[face_lo], half_g * hl_e**2, pl))
        pc[(1,) + face_lo] = np.where(none, 0.0, np.where(dry[face_lo], half_g * hr_e**2, pr))
    # the draining factor of the cells updated (interior along d), 1 elsewhere
    g = lay.gx if d == 0 else lay.gy
    m = lay.nx if d == 0 else lay.ny
    Hm = np.zeros_like(H)  # the face on the low side of each cell
    Hm[sl(1, n)] = H[sl(0, n - 1)]
    out = lam * (np.maximum(H[0], 0.0) - np.minimum(Hm[0], 0.0))
    theta = np.ones(h.shape)
    inner = sl(g, g + m)[1:]

    def ratio(th, out, have):  # th, lowered to have / out where out th exceeds what it has
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(out * th > have, have / np.where(out > 0, out, 1.0), th)

    th = ratio(np.ones(h.shape), out, q[0])
    if lay.segregation:  # small particles, then large ones
        P = lay.HPHI
        th = ratio(th, lam * (np.maximum(H[P], 0.0) - np.minimum(Hm[P], 0.0)), q[P])
        out_l = lam * (np.maximum(H[0] - H[P], 0.0) - np.minimum(Hm[0] - Hm[P], 0.0))
        th = ratio(th, out_l, q[0] - q[P])
    if drain:
        theta[inner] = th[inner]
        if c.bc[2 * d] == "periodic":  # the ghost cells are their images (one face, one factor)
            theta[sl(g - 1, g)[1:]] = theta[sl(g + m - 1, g + m)[1:]]
            theta[sl(g + m, g + m + 1)[1:]] = theta[sl(g, g + 1)[1:]]
    theta_hi = np.ones(h.shape)  # the factor of each face's high-side cell
    theta_hi[sl(0, n - 1)[1:]] = theta[sl(1, n)[1:]]
    fac = np.where(H[0] > 0.0, theta, np.where(H[0] < 0.0, theta_hi, 1.0))
    Hs = H * fac[None]
    ix, iy = lay.interior()
    Hsm = np.zeros_like(Hs)
    Hsm[sl(1, n)] = Hs[sl(0, n - 1)]
    if ref.projected:  # no momentum into a resting film from a resting neighbour
        cells = sl(1, n - 1)
        Hsm[cells], Hs[cells] = ref.film_faces(
            Hsm[cells], Hs[cells], start, cells[1:], sl(0, n - 2)[1:], sl(2, n)[1:]
        )
    upd = -lam * (Hs - Hsm)
    if ref.bed is not None:  # the corrections of the cell's faces and its centred source
        pc_lo = np.zeros_like(pc[1])
        pc_lo[sl(1, n)[1:]] = pc[1][sl(0, n - 1)[1:]]
        cen = 0.5 * ref.gravity_part(gcell, 1) * (eW[0] + eE[0]) * (bW - bE)
        upd[mom] = upd[mom] + dt * inv * cen - lam * (pc[0] - pc_lo)
    if d == 0:  # g sin(zeta) h by the trapezoidal rule (the source without friction)
        h1 = q[0] + upd[0]
        gs = ref.gravity_part(gcell, 0)
        upd[lay.HU] += 0.5 * dt * (q[0] * gs + h1 * gs)
        hbar = 0.5 * (q[0] + h1)
        if terms is not None:
            upd = upd + dt * terms
    if ref.solid is not None:  # a solid cell never changes
        upd = np.where(ref.solid[None], 0.0, upd)
    q[:, ix, iy] = q[:, ix, iy] + upd[:, ix, iy]
    if limit:
        ref.postprocess(q)
    if last and ref.projected:  # the friction of the whole step, at its initial speeds
        project_step(ref, q, dt, start, None if hbar is None else hbar[ix, iy])
    # boundary amounts: the scaled fluxes through the domain's two faces along d
    lo = Hs[sl(g - 1, g)]
    hi = Hs[sl(g + m - 1, g + m)]
    cross = iy if d == 0 else ix
    ds = c.dy if d == 0 else c.dx
    net = (lo - hi)[(slice(None),) + ((slice(None), cross) if d == 0 else (cross, slice(None)))]
    mass = float(dt * net[lay.H].sum() * ds)
    small = float(dt * net[lay.HPHI].sum() * ds) if lay.segregation else 0.0
    out = {"mass": mass, "small_mass": small}
    if d == 0 and not last:
        out["hbar"] = hbar
    return out


def project_step(
    ref: ReferenceOperator,
    q: np.ndarray,
    dt: float,
    start: np.ndarray,
    hbar: np.ndarray | None = None,
) -> None:
    """The friction of a whole split step over dt, in place on q's interior cells, at the
    speeds of the step's initial primitives ``start``, on the interior thicknesses ``hbar``
    that the step's gravity acted on (q's own where None: no gravity acted), the cells at rest there held where a law with
    hysteresis holds them (the last sub-step's projection)."""
    lay = ref.lay
    ix, iy = lay.interior()
    still = start[lay.HU] == 0
    if not lay.is_1d:
        still = still & (start[lay.HV] == 0)
    inner_q = q[:, ix, iy]
    g = ref.inner_gravity()
    held = ref.holds(inner_q, dt, still[ix, iy], g)
    project(ref, inner_q, dt, ref._magnitude(start)[ix, iy], held, hbar, g)
    q[:, ix, iy] = inner_q


def viscous_rate(ref: ReferenceOperator, q: np.ndarray, t: float) -> np.ndarray:
    """V(q): the divergence of the viscous stresses of (6.2) alone on the interior cells, zero
    elsewhere (SplitSweeps._viscous_faces), with no stress through a running inlet; fills
    q's ghost cells at time t."""
    c, lay = ref.cfg, ref.lay
    ref.fill_ghosts(q, t)
    w = split_primitives(ref, q)
    if c.bc[0] == "inflow" and not t > c.inflow_stop:
        # no viscous stress through a running inlet (ViscousSubstep._inlet_velocities)
        ys = slice(*inlet_rows(lay, c.inflow_rows))
        for comp in (lay.HU,) if lay.is_1d else (lay.HU, lay.HV):
            w[comp, : lay.gx, ys] = w[comp, lay.gx, ys][None]
    Px, Py = ref.viscous_fluxes(w)
    ix, iy = lay.interior()
    ixm = slice(ix.start - 1, ix.stop - 1)
    out = np.zeros_like(q)
    div = (Px[:, ix, iy] - Px[:, ixm, iy]) / c.dx
    if not lay.is_1d:
        iym = slice(iy.start - 1, iy.stop - 1)
        div = div + (Py[:, ix, iy] - Py[:, ix, iym]) / c.dy
    out[:, ix, iy] = div
    return out


def viscous_substep(
    ref: ReferenceOperator,
    q: np.ndarray,
    t: float,
    dt: float,
    stages: int,
) -> None:
    """The viscous sub-step V of a split step (ViscousSubstep.viscous_stage), in place: ``stages``
    RKC stages (rkc_coefficients) over dt from t, the recurrence written for the increments
    Y_j - Y0, on the interior cells; then the stage limiter. V closes no step, so it projects
    no friction (`hancock_pair`)."""
    mu_t1, coeffs, cs = rkc_coefficients(stages)
    ix, iy = ref.lay.interior()
    y0 = q.copy()
    f0 = viscous_rate(ref, y0.copy(), t)
    prev2, prev1 = y0, y0 + mu_t1 * dt * f0
    for j in range(2, stages + 1):
        mu, nu, mu_t, gamma_t = coeffs[j - 2]
        f = viscous_rate(ref, prev1.copy(), t + cs[j - 1] * dt)
        inc = mu * (prev1 - y0) + nu * (prev2 - y0) + mu_t * dt * f + gamma_t * dt * f0
        prev2, prev1 = prev1, y0 + inc
    q[:, ix, iy] = prev1[:, ix, iy]
    ref.postprocess(q)


def project(
    ref: ReferenceOperator, q: np.ndarray, tau: float, spd0, held=None, hbar=None, g=None
) -> None:
    """Physics.project_friction over tau, in place on conserved states q, with the friction
    coefficient at the speeds spd0 (ReferenceOperator.project_friction, which takes them
    from a state); ``held``: cells a law with hysteresis holds at rest; ``hbar``: the
    thickness the impulse acts on (q's own h if None); ``g``: the bend's gravity of q's cells
    where q holds the interior only (ReferenceOperator.inner_gravity)."""
    lay = ref.lay
    if tau <= 0:
        return
    wet, hs, hmu, phi = ref._friction_cells(q)
    m = ref._magnitude(q)
    hb = hs if hbar is None else hbar
    gn = ref.g_normal_q(q, hs, g)
    imp = tau * gn * ref.mu_g(hmu, spd0, phi, gn) * hb
    f = np.where(m > imp, 1.0 - imp / np.where(m > 0, m, 1.0), 0.0)
    f = np.where(wet, f, 1.0)
    if held is not None:
        f = np.where(held, 0.0, f)
    q[lay.HU] *= f
    if not lay.is_1d:
        q[lay.HV] *= f


def hancock_step(
    ref: ReferenceOperator, q: np.ndarray, t: float, dt: float, dirs, start=None
) -> dict:
    """One step of the split scheme without viscosity (tiseg.solver.timestepping.split.Hancock)
    or a half step of one with it (`hancock_pair`): sweeps along ``dirs`` in order, 0 (x) and
    1 (y), the first taking the step's initial state (rest mask and speeds of the projected
    friction; ``start``: the primitives of another state to take them from), the last
    projecting the friction. Returns the summed budget."""
    if start is None:
        ref.fill_ghosts(q, t)
        start = ref.rest_view(split_primitives(ref, q), t)
    out = {"mass": 0.0, "small_mass": 0.0}
    hbar = None  # the thickness the x sweep's gravity acted on, for a y sweep that closes
    for k, d in enumerate(dirs):
        last = k == len(dirs) - 1
        b = hancock_sweep(ref, q, t, dt, d, start=start, last=last, hbar=hbar)
        hbar = b.get("hbar")
        out["mass"] += b["mass"]
        out["small_mass"] += b["small_mass"]
    return out


def hancock_pair(
    ref: ReferenceOperator, q: np.ndarray, t: float, dt: float, dirs, visc_stages: int = 2
) -> dict:
    """One step of the split scheme with viscosity (tiseg.solver.timestepping.split.Hancock
    with ``viscous``), in place: the half step of sweeps ``dirs`` over dt/2 from t (friction
    projected over its half at its end), the viscous sub-step of ``visc_stages`` RKC stages
    over the whole dt from t, then the sweeps ``dirs`` reversed over dt/2 from t + dt/2, whose
    rest mask and speeds are those of the state V started from, the last projecting the
    friction of the second half. Returns the summed budget."""
    half = 0.5 * dt
    out = hancock_step(ref, q, t, half, dirs)
    ref.fill_ghosts(q, t)
    start = ref.rest_view(split_primitives(ref, q), t)
    viscous_substep(ref, q, t, dt, visc_stages)
    back = hancock_step(ref, q, t + half, half, list(dirs)[::-1], start=start)
    return {k: out[k] + back[k] for k in out}
