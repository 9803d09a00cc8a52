"""NumPy reference of the semi-discrete operator dq/dt = L(q, t) for (6.1)-(6.6).

The discretisation (identical in `tiseg.solver.numerics.operator`):

1. Ghost cells from the boundary conditions (inflow (6.8)-(6.9), outflow, periodic, wall).
2. Cell primitives w = (h, u, v, phi) with Kurganov-Petrova desingularisation
   u = sqrt(2) h (hu) / sqrt(h^4 + max(h^4, h_eps^4)) (a dimensional h_eps:
   Kurganov-Petrova's eps = dx^4 is not dimensionless and over-damps mm-thick flows in SI units).
3. Slopes of w per direction: zero (first order), minmod-theta, or a WENO-type weighted slope
   (smoothness indicators made dimensionless with h_ref, u_ref); then limited so that the
   edge values keep h >= 0 and 0 <= phi <= 1.
4. A central flux at each face (``numerics.flux``), zero where both neighbouring cells are
   thinner than h_min (with the projected friction: and were so at the step's start, see
   `ReferenceOperator.rhs`; in the split sweeps only where neither moves or moved then):

   * ``kt``, Kurganov-Tadmor (2000): H = (f(q_L) + f(q_R))/2 - a/2 (q_R - q_L), with the local
     speed a = max(|u| + sqrt(g h cos zeta), |u (1 - G'(phi))|) over both edge states
     (segregation wave speed (5.26) included);
   * ``central-upwind``, Kurganov, Noelle & Petrova (2001):
     H = (a+ f(q_L) - a- f(q_R))/(a+ - a-) + a+ a- / (a+ - a-) (q_R - q_L), with
     a+ = max(u + c, u (1 - G'), 0) and a- = min(u - c, u (1 - G'), 0) over both edge states
     (H = (f_L + f_R)/2 if a+ = a- = 0).
   * ``rusanov``, the local Lax-Friedrichs flux of Rusanov (1961): the formula of ``kt``.

   With ``numerics.phi_flux = "upwind"`` the h phi component becomes F_h (phi - G(phi)), F_h the
   mass component of H and phi that of the edge state upwind of F_h (Larrouturou 1991).
5. Viscous stress div(nu h^{3/2} D) (6.2), (6.6): face coefficient K = harmonic mean of
   nu h^{3/2} of the two cells (zero if either is thinner than h_min), central differences with
   the cross derivatives averaged over four cells.
6. Source g h S (6.4) with mu_b from (3.4), (3.7), the direction u/|u| regularised as
   u / max(|u|, u_eps); no source where h < h_min (in the split sweeps, where h = 0, the
   law then evaluated at h_min).

Arrays are shaped (nc, NX, NY) as in `tiseg.solver.numerics.config.Layout`.
"""

from __future__ import annotations

import math

import numpy as np

from ..numerics.boundaries import BOUNDARIES
from ..numerics.config import OperatorConfig
from ..numerics.fluxes import FLUXES, PHI_FLUXES
from ..numerics.reconstruction import RECONSTRUCTIONS, limit_edges_np
from ...model.physics.friction import FRICTION_LAWS
from ...model.physics.segregation import TRANSPORTS
from ...model.physics.sources import SOURCES, NumpyContext, aux_arrays
from ..numerics.bed import bed_with_ghosts
from ...model.bed_line import gravity_columns
from .bed import bed_rate, eta_slopes, star_states
from .walls import FLUID, SOLID, WALL_HI, WALL_LO, face_kinds, faced
from ...model.physics.viscosity import VISCOSITY

SQRT2 = math.sqrt(2.0)


class ReferenceOperator:
    """dq/dt for a full array with ghost cells (ghosts are overwritten)."""

    def __init__(
        self,
        cfg: OperatorConfig,
        y_centres: np.ndarray | None = None,
        bed: np.ndarray | None = None,
        solid: np.ndarray | None = None,
    ):
        """``bed``: the bed heights (nx, ny) [m] of a config with a bed (flat where None);
        ``solid``: the solid cells (nx, ny) of a config with them (none where None)."""
        self.cfg = cfg
        self.lay = cfg.layout
        lay = self.lay
        self.bed = None
        if cfg.bed:  # with its ghost cells, as the operator's (OperatorState.set_bed)
            flat = np.zeros((lay.nx, lay.ny))
            self.bed = bed_with_ghosts(flat if bed is None else bed, lay, cfg.bc)
        self._pc = {}  # the bed's face corrections of the last face_fluxes, per axis
        self.solid = None
        if cfg.solid:  # solid cells, ghost cells as the operator's
            flat = np.zeros((lay.nx, lay.ny))
            mask = flat if solid is None else np.asarray(solid, dtype=float)
            self.solid = bed_with_ghosts(mask, lay, cfg.bc) > 0.5
        if y_centres is None:
            y_centres = (np.arange(lay.ny) + 0.5) * cfg.dy
        self.y = np.asarray(y_centres, dtype=float)
        # friction as a projection after each stage (project_friction), not in the source
        self.projected = cfg.friction_projected
        self.films = bool(cfg.split)  # films thinner than h_min flow (Physics.acts)
        self.law = FRICTION_LAWS[cfg.friction]
        self.transport = TRANSPORTS[cfg.transport]
        # the numerics components, whose NumPy twins the steps below call
        self.bcs = tuple(BOUNDARIES[b] for b in cfg.bc)
        self.rec = RECONSTRUCTIONS[cfg.reconstruction]
        self.num_flux = FLUXES[cfg.flux]
        self.phi_flux = PHI_FLUXES[cfg.phi_flux]
        # the scene's source terms beyond (6.4) and the fields they read (their twins)
        self.aux = aux_arrays(cfg)
        # a run-out's bend: (g sin zeta, g cos zeta, kappa) per column (3, NX, 1) and per x
        # face (3, NX - 1, 1) (tiseg.solver.numerics.gravity); None on a plane
        self.gcell = self.gface = None
        if cfg.bend is not None:
            cells, faces = gravity_columns(cfg.bed_line(), cfg.g, cfg.dx, lay.gx, lay.NX)
            self.gcell = cells.T[:, :, None]
            self.gface = faces.T[:, :-1, None]

    # ------------------------------------------------------------------ boundaries
    def fill_ghosts(self, q: np.ndarray, t: float) -> None:
        """Ghost cells from the boundary conditions' twins (tiseg.solver.numerics.boundaries): x
        first (over all rows), y second (over all columns, corners included), layer k of the
        low side before that of the high side."""
        lay = self.lay
        for d in (0,) if lay.is_1d else (0, 1):
            lo, hi = self.bcs[2 * d], self.bcs[2 * d + 1]
            for k in range(lay.gx if d == 0 else lay.gy):
                lo.fill_np(self, q, t, d, 0, k)
                hi.fill_np(self, q, t, d, 1, k)

    # ------------------------------------------------------------------ pointwise physics
    def primitives(self, q: np.ndarray) -> np.ndarray:
        """w = (h, u[, v][, phi]) with Kurganov-Petrova desingularisation."""
        c, lay = self.cfg, self.lay
        h = np.maximum(q[lay.H], 0.0)
        h4 = h**4
        denom = np.sqrt(h4 + np.maximum(h4, c.h_eps**4))
        return self.primitives_of(q, h, lambda m: SQRT2 * h * m / denom)

    def primitives_of(self, q: np.ndarray, h: np.ndarray, velocity) -> np.ndarray:
        """w of q with h = max(q_h, 0), each velocity ``velocity(momentum)`` and phi bounded."""
        lay = self.lay
        w = np.empty_like(q)
        w[0] = h
        for comp in range(1, lay.nc):
            w[comp] = velocity(q[comp])
        if lay.segregation:
            # phi = h phi / h, bounded; no desingularisation (it would bias thin films to 0)
            safe = np.where(h > 0, h, 1.0)
            w[lay.HPHI] = np.where(h > 0, np.clip(q[lay.HPHI] / safe, 0.0, 1.0), 0.0)
        return w

    def G(self, phi):
        """The transport function's NumPy twin, (2.17) or (2.18)."""
        return self.transport.G_np(phi, self.cfg.alpha)

    def dG(self, phi):
        return self.transport.dG_np(phi, self.cfg.alpha)

    def _weight(self, phi):
        """The concentration a mixture law weights with: local phi with feedback."""
        return phi if self.cfg.feedback and self.law.weighted else self.cfg.phi_ref

    def mu_b(self, h, speed, phi):
        """Basal friction coefficient of the configured law (the NumPy twin in
        tiseg.model.physics.friction), e.g. (3.4) with (3.7)."""
        return self.law.mu_np(self.cfg, h, speed, self._weight(phi))

    def mu_start(self, h, phi):
        """The largest coefficient at rest (mu_S(h) of a law with hysteresis)."""
        return self.law.mu_start_np(self.cfg, h, self._weight(phi))

    def g_normal(self, u, g):
        """Physics.g_normal: g cos zeta, on a bend (g is (g sin, g cos, kappa) arrays) plus
        kappa u^2, clipped at 0."""
        if g is None:
            return self.cfg.g_cos
        return np.maximum(g[1] + g[2] * u * u, 0.0)

    def mu_g(self, h, speed, phi, gn):
        """Physics.mu_g: mu_b at the Froude number |u| / sqrt(gn h) on a bend."""
        if self.gcell is not None:
            gc = self.cfg.g_cos
            speed = speed * np.sqrt(gc / np.maximum(gn, 1e-6 * gc))
        return self.mu_b(h, speed, phi)

    def wave(self, w, g):
        """Physics.wave: sqrt(g cos zeta h), on a bend sqrt(gn h) + |kappa h u|."""
        if g is None:
            return np.sqrt(self.cfg.g_cos * w[0])
        return np.sqrt(self.g_normal(w[1], g) * w[0]) + np.abs(g[2] * w[0] * w[1])

    def flux(self, w: np.ndarray, direction: int, g=None) -> np.ndarray:
        """Physical flux f (x) or g (y) of the primitive state w, as conserved components;
        ``g``: the faces' gravity on a bend (None: the plane's)."""
        lay = self.lay
        h, u = w[0], w[1]
        vel = u if direction == 0 else w[lay.HV]
        f = np.empty_like(w)
        f[lay.H] = h * vel
        f[lay.HU] = h * u * vel
        if not lay.is_1d:
            f[lay.HV] = h * w[lay.HV] * vel
        f[lay.HU if direction == 0 else lay.HV] += 0.5 * self.g_normal(u, g) * h * h
        if lay.segregation:
            phi = w[lay.HPHI]
            f[lay.HPHI] = h * vel * (phi - self.G(phi))
        return f

    def speed(self, w: np.ndarray, direction: int, g=None) -> np.ndarray:
        lay = self.lay
        vel = w[1] if direction == 0 else w[lay.HV]
        a = np.abs(vel) + self.wave(w, g)
        if lay.segregation:
            a = np.maximum(a, np.abs(vel * (1.0 - self.dG(w[lay.HPHI]))))
        return a

    def speed_range(self, w: np.ndarray, direction: int, g=None):
        """(smallest, largest) characteristic speed: u -+ c widened by u (1 - G'(phi))."""
        lay = self.lay
        vel = w[1] if direction == 0 else w[lay.HV]
        cc = self.wave(w, g)
        lo, hi = vel - cc, vel + cc
        if lay.segregation:
            s = vel * (1.0 - self.dG(w[lay.HPHI]))
            lo, hi = np.minimum(lo, s), np.maximum(hi, s)
        return lo, hi

    def conserved(self, w: np.ndarray) -> np.ndarray:
        q = w.copy()
        q[1:] = w[1:] * w[0]
        return q

    # ------------------------------------------------------------------ reconstruction
    def slopes(self, w: np.ndarray, axis: int) -> np.ndarray:
        """Undivided slopes (edge value = w +- slope/2) along axis 1 (x) or 2 (y); zero at the
        outermost ghost layer."""
        s = np.zeros_like(w)
        if not self.rec.slopes:
            return s
        wm = np.take(w, range(0, w.shape[axis] - 2), axis=axis)
        w0 = np.take(w, range(1, w.shape[axis] - 1), axis=axis)
        wp = np.take(w, range(2, w.shape[axis]), axis=axis)
        dm, dp, dc = w0 - wm, wp - w0, 0.5 * (wp - wm)
        inner = self.rec.slope_np(self.cfg, self.lay, dm, dp, dc)
        limit_edges_np(self.lay, inner, w0)  # keep edge values physical
        idx = [slice(None)] * w.ndim
        idx[axis] = slice(1, w.shape[axis] - 1)
        s[tuple(idx)] = inner
        return s

    # ------------------------------------------------------------------ the operator
    def face_fluxes(self, w: np.ndarray, axis: int, start: np.ndarray | None = None) -> np.ndarray:
        """Numerical flux (step 4) at faces between cells m and m+1 along axis; shape like w with the
        face m+1/2 stored at index m (last index unused). ``start``: the primitives of the
        step's initial state, whose rest and wet cells decide the projected friction's face
        rules (default w itself, the step's first evaluation)."""
        start = w if start is None else start
        direction = axis - 1
        s = self.slopes(w, axis)
        n = w.shape[axis]

        def sl(a, b):
            idx = [slice(None)] * w.ndim
            idx[axis] = slice(a, b)
            return tuple(idx)

        wl = (w + 0.5 * s)[sl(0, n - 1)]  # east/north edge of cell m
        wr = (w - 0.5 * s)[sl(1, n)]  # west/south edge of cell m+1
        kinds = np.zeros(wl.shape[1:], dtype=int)
        if self.solid is not None:  # walls: the fluid side and its mirror
            kinds = face_kinds(self.solid, axis)
            wl, wr = faced(self.lay, kinds, wl, wr, direction)
        if self.bed is not None:  # the hydrostatic reconstruction (tiseg.solver.reference.bed)
            es = eta_slopes(self, w, self.bed, axis, self.solid)
            eta = w[0] + self.bed
            bl = (eta + 0.5 * es - (w[0] + 0.5 * s[0]))[sl(0, n - 1)[1:]]
            br = (eta - 0.5 * es - (w[0] - 0.5 * s[0]))[sl(1, n)[1:]]
            br = np.where(kinds == WALL_HI, bl, br)
            bl = np.where((kinds == WALL_LO) | (kinds == SOLID), br, bl)
            hl, hr = wl[0], wr[0]
            wl, wr, pl, pr = star_states(self, wl, bl, wr, br, self.face_gravity(axis))
        H = self.numerical_flux(wl, wr, direction, self.face_gravity(axis))
        if self.projected:  # the near-rest face rules (RestRules.rest_face), not at walls
            Hr = H.copy()
            self.rest_faces(Hr, wl, wr, start, direction, sl(0, n - 1)[1:], sl(1, n)[1:])
            H = np.where((kinds == FLUID)[None], Hr, H)
        dry = self.dry_faces(w, start, sl(0, n - 1)[1:], sl(1, n)[1:]) | (kinds == SOLID)
        H = np.where(dry[None], 0.0, H)
        if self.bed is not None:  # a face without convective flux: each side's pressure
            half_g = 0.5 * self.gravity_part(self.face_gravity(axis), 1)
            p = np.zeros((2,) + w.shape[1:])
            none = kinds == SOLID
            p[(0,) + sl(0, n - 1)[1:]] = np.where(none, 0.0, np.where(dry, half_g * hl * hl, pl))
            p[(1,) + sl(0, n - 1)[1:]] = np.where(none, 0.0, np.where(dry, half_g * hr * hr, pr))
            self._pc[axis] = (p, s, es)
        out = np.zeros_like(w)
        out[sl(0, n - 1)] = H
        return out

    def acts(self, h: np.ndarray) -> np.ndarray:
        """Where sources and friction act (Physics.acts): h > 0 in the split sweeps, whose
        films flow, h >= h_min in the unsplit scheme."""
        return h > 0.0 if self.films else h >= self.cfg.h_min

    def moving(self, w: np.ndarray) -> np.ndarray:
        """Cells of primitives w with a velocity (RestRules.moving)."""
        lay = self.lay
        m = w[lay.HU] != 0
        if not lay.is_1d:
            m |= w[lay.HV] != 0
        return m

    def dry_faces(self, w, start, lo, hi) -> np.ndarray:
        """The faces that carry no convective flux (FiniteVolume.face_wet): both cells
        thinner than h_min, with the projected friction at the step's start (primitives
        ``start``) too; where films flow (split sweeps) also neither moving (at the step's
        start with the projected friction). lo and hi index the cells below and above each
        face."""
        c = self.cfg
        hc = w[0]
        dry = np.maximum(hc[lo], hc[hi]) < c.h_min
        if self.projected:
            h0 = start[0]
            dry &= np.maximum(h0[lo], h0[hi]) < c.h_min
            if self.films:
                still = ~self.moving(start)
                dry &= still[lo] & still[hi]
        elif self.films:
            dry &= ~(self.moving(w)[lo] | self.moving(w)[hi])
        return dry

    def rest_faces(self, H, wl, wr, w, direction, lo, hi) -> None:
        """The projected friction's face rules (RestRules.rest_face), in place on the
        face fluxes H between edge states wl | wr along direction: w holds the primitives of
        the cells whose rest decides (the step's initial state), lo and hi index the cells
        below and above each face."""
        lay = self.lay
        still = w[lay.HU] == 0
        if not lay.is_1d:
            still &= w[lay.HV] == 0
        both = still[lo] & still[hi]  # no mass or h phi crosses
        # the upwind cell outruns its neighbour: at least f_u - f_d^2 / f_u crosses
        c_n = lay.HU if direction == 0 else lay.HV
        un = w[c_n]  # the cells' normal speeds
        towards_r = (un[lo] > 0) & ~(un[hi] < 0)
        towards_l = (un[hi] < 0) & ~(un[lo] > 0)

        def bound(fu, fd, sF):
            # f_u - f_d^2 / f_u where it lies above s F (tested first without the division,
            # as the kernel does), else no bound (-inf)
            over = (fu > 0) & (fu * fu - fd * fd > sF * fu)
            safe = np.where(fu > 0, fu, 1.0)
            return np.where(over, fu - fd * fd / safe, -np.inf)

        f_lo = bound(
            wl[lay.H] * np.maximum(wl[c_n], 0.0),
            wr[lay.H] * np.maximum(wr[c_n], 0.0),
            H[lay.H],
        )
        f_hi = -bound(
            -wr[lay.H] * np.minimum(wr[c_n], 0.0),
            -wl[lay.H] * np.minimum(wl[c_n], 0.0),
            -H[lay.H],
        )
        up_r = ~both & towards_r & (f_lo > H[lay.H])
        up_l = ~both & towards_l & (f_hi < H[lay.H])
        floor = np.where(up_r, f_lo, np.where(up_l, f_hi, 0.0))  # finite where it applies
        if lay.segregation:
            p = np.where(up_r, wl[lay.HPHI], wr[lay.HPHI])  # the upwind cell's phi
            H[lay.HPHI] = np.where(
                both, 0.0, np.where(up_r | up_l, floor * (p - self.G(p)), H[lay.HPHI])
            )
        H[lay.H] = np.where(both, 0.0, np.where(up_r | up_l, floor, H[lay.H]))

    def face_gravity(self, axis: int):
        """The gravity of the faces along ``axis`` (1: x faces, 2: y faces, at the columns'
        centres) on a bend, None on a plane."""
        if self.gcell is None:
            return None
        return self.gface if axis == 1 else self.gcell

    def gravity_part(self, g, k: int):
        """Component k of a gravity vector g (0: g sin zeta, 1: g cos zeta), the plane's
        number where g is None."""
        if g is None:
            return self.cfg.g_sin if k == 0 else self.cfg.g_cos
        return g[k]

    def numerical_flux(self, wl: np.ndarray, wr: np.ndarray, direction: int, g=None) -> np.ndarray:
        """The face flux of step 4 between edge states wl | wr (primitives) along direction:
        the numerical flux's twin, then (with segregation) the phi modifier's; ``g``: the
        faces' gravity on a bend."""
        H = self.num_flux.flux_np(self, wl, wr, direction, g)
        if self.lay.segregation:
            H = self.phi_flux.modify_np(self, H, wl, wr)
        return H

    def viscous_fluxes(self, w: np.ndarray):
        """Face stresses P (x faces, y faces) to be subtracted from the KT fluxes of hu, hv."""
        c, lay = self.cfg, self.lay
        h, u = w[0], w[1]
        Px = np.zeros_like(w)
        Py = np.zeros_like(w)

        def face_K(ha, hb):  # the component's twin (tiseg.model.physics.viscosity)
            return VISCOSITY.face_K_np(ha, hb, c.nu, c.h_min)

        Kx = face_K(h[:-1], h[1:])  # face i+1/2 at index i
        Px[lay.HU, :-1] = Kx * (u[1:] - u[:-1]) / c.dx
        if lay.is_1d:
            return Px, Py
        v = w[lay.HV]
        dx, dy = c.dx, c.dy
        # x faces: cross derivative du/dy averaged over cells i, i+1 (rows j-1, j+1)
        dudy = np.zeros_like(u)
        dudy[:-1, 1:-1] = ((u[:-1, 2:] - u[:-1, :-2]) + (u[1:, 2:] - u[1:, :-2])) / (4 * dy)
        Px[lay.HV, :-1] = 0.5 * Kx * ((v[1:] - v[:-1]) / dx + dudy[:-1])
        Ky = face_K(h[:, :-1], h[:, 1:])
        Py[lay.HV, :, :-1] = Ky * (v[:, 1:] - v[:, :-1]) / dy
        dvdx = np.zeros_like(v)
        dvdx[1:-1, :-1] = ((v[2:, :-1] - v[:-2, :-1]) + (v[2:, 1:] - v[:-2, 1:])) / (4 * dx)
        Py[lay.HU, :, :-1] = 0.5 * Ky * ((u[:, 1:] - u[:, :-1]) / dy + dvdx[:, :-1])
        return Px, Py

    def terms(self, w: np.ndarray) -> np.ndarray:
        """The rates of the scene's source terms beyond (6.4) (their NumPy twins,
        tiseg.model.physics.sources), from primitives with ghost cells filled; zero without
        terms."""
        out = np.zeros_like(w)
        ctx = NumpyContext(w, self.aux, dict(self.cfg.constants), self.cfg)
        for name in self.cfg.sources:
            out = out + SOURCES[name].rate_np(ctx)
        return out

    def source(self, w: np.ndarray) -> np.ndarray:
        """g h S of (6.4) (films thinner than h_min included, Physics.source)."""
        c, lay = self.cfg, self.lay
        h, u = w[0], w[1]
        v = np.zeros_like(u) if lay.is_1d else w[lay.HV]
        speed = np.sqrt(u * u + v * v)
        phi = w[lay.HPHI] if lay.segregation else c.phi_ref
        g = self.gcell
        gn = self.g_normal(u, g)
        mu = self.mu_g(np.maximum(h, c.h_min), speed, phi, gn)  # (Physics.film_h)
        inv = 1.0 / np.maximum(speed, c.u_eps)
        wet = self.acts(h)
        S = np.zeros_like(w)
        if self.projected:  # the friction is project_friction's
            mu = np.zeros_like(mu)
        S[lay.HU] = np.where(wet, h * (self.gravity_part(g, 0) - gn * mu * u * inv), 0.0)
        if not lay.is_1d:
            S[lay.HV] = np.where(wet, -h * gn * mu * v * inv, 0.0)
        return S

    def project_friction(self, q: np.ndarray, tau: float, q0: np.ndarray, held=None) -> None:
        """The projected friction over tau, in place (Physics.project_friction): momentum
        shrinks by tau g cos(zeta) mu_b h along itself, or stops where that cancels it; mu_b
        at the speed of q0, the state the stage started from. ``held``: the cells the static
        friction of a law with hysteresis holds for the step (`holds`), which stay at
        rest."""
        lay = self.lay
        if not self.projected or tau <= 0:
            return
        wet, hs, hmu, phi = self._friction_cells(q)
        m = self._magnitude(q)
        spd0 = self._magnitude(self.primitives(q0))
        gn = self.g_normal_q(q, hs)
        imp = tau * gn * self.mu_g(hmu, spd0, phi, gn) * hs
        f = np.where(m > imp, 1.0 - imp / np.where(m > 0, m, 1.0), 0.0)
        f = np.where(wet, f, 1.0)
        if held is not None:
            f = np.where(held, 0.0, f)
        q[lay.HU] *= f
        if not lay.is_1d:
            q[lay.HV] *= f

    def _magnitude(self, a):
        """|(a[1], a[HV])|: the speed of a primitive state, |h u| of a conserved one
        (Physics.speed_mag)."""
        lay = self.lay
        x = a[lay.HU]
        return np.abs(x) if lay.is_1d else np.sqrt(x * x + a[lay.HV] * a[lay.HV])

    def _friction_cells(self, q):
        """(wet: where the friction acts (Physics.acts), h with 1 elsewhere, the h the law is
        evaluated at (h_min in films thinner than that: Physics.film_h), phi the friction
        weights with) of a conserved state."""
        c, lay = self.cfg, self.lay
        wet = self.acts(q[lay.H])
        hs = np.where(wet, q[lay.H], 1.0)
        phi = np.clip(q[lay.HPHI] / hs, 0.0, 1.0) if lay.segregation else c.phi_ref
        return wet, hs, np.maximum(hs, c.h_min), phi

    def g_normal_q(self, q, hs, g=None):
        """Physics.g_normal_q: the normal load at the velocity of the conserved q (hs: its
        thickness, 1 where dry); ``g``: the cells' gravity where q is not the whole grid
        (`inner_gravity`), else the columns'."""
        if self.gcell is None:
            return self.cfg.g_cos
        return self.g_normal(q[self.lay.HU] / hs, self.gcell if g is None else g)

    def inner_gravity(self):
        """The bend's gravity of the interior columns (None on a plane), for states that hold
        the interior cells only."""
        return None if self.gcell is None else self.gcell[:, self.lay.interior()[0]]

    def holds(self, q: np.ndarray, tau: float, at_rest, g=None) -> np.ndarray:
        """Physics.holds: of the cells ``at_rest`` at the step's start, those whose first-stage
        state q (one Euler step of tau) has |h u| <= tau g cos(zeta) mu_S(h) h: the static
        friction holds them for the step (a law with hysteresis; no cell otherwise)."""
        lay = self.lay
        if not (self.projected and self.law.hysteresis) or tau <= 0:
            return np.zeros_like(q[lay.H], dtype=bool)
        wet, hs, hmu, phi = self._friction_cells(q)
        static = tau * self.g_normal_q(q, hs, g) * self.mu_start(hmu, phi) * hs
        return at_rest & wet & (self._magnitude(q) <= static)

    def at_rest(self, q: np.ndarray) -> np.ndarray:
        """Cells whose primitive velocity is exactly zero (the rest mask of a step's start)."""
        w = self.primitives(q)
        lay = self.lay
        r = w[lay.HU] == 0
        if not lay.is_1d:
            r &= w[lay.HV] == 0
        return r

    def rhs(self, q: np.ndarray, t: float, start: np.ndarray | None = None) -> np.ndarray:
        """dq/dt on interior cells (ghost entries of the result are zero); fills q's ghosts.

        ``start``: the step's initial state (ghost cells filled here, at t), for a later stage
        of a step. With the projected friction its cells decide the face rules: which cells
        are at rest (`rest_faces`), and which faces carry a flux although both their cells are
        now thinner than h_min (one of them was not at the step's start:
        FiniteVolume.face_wet). Default: q itself, the step's first evaluation."""
        c, lay = self.cfg, self.lay
        self.fill_ghosts(q, t)
        w = self.primitives(q)
        w0 = w
        if start is not None:
            s0 = np.array(start, dtype=float)
            self.fill_ghosts(s0, t)
            w0 = self.primitives(s0)
        w0 = self.rest_view(w0, t)
        Fx = self.face_fluxes(w, 1, w0)
        Fy = None if lay.is_1d else self.face_fluxes(w, 2, w0)
        if c.viscous:
            Px, Py = self.viscous_fluxes(w)
            Fx = Fx - Px
            if Fy is not None:
                Fy = Fy - Py
        ix, iy = lay.interior()
        out = np.zeros_like(q)
        ixm = slice(ix.start - 1, ix.stop - 1)
        div = -(Fx[:, ix, iy] - Fx[:, ixm, iy]) / c.dx
        if Fy is not None:
            iym = slice(iy.start - 1, iy.stop - 1)
            div = div - (Fy[:, ix, iy] - Fy[:, ix, iym]) / c.dy
        out[:, ix, iy] = div + self.source(w)[:, ix, iy]
        if self.bed is not None:  # the bed's pressure along each direction
            for axis in (1,) if lay.is_1d else (1, 2):
                p, s, es = self._pc[axis]
                comp = lay.HU if axis == 1 else lay.HV
                r = bed_rate(self, w, s, es, self.bed, p[0], p[1], axis)
                out[comp, ix, iy] += r[ix, iy]
        if self.solid is not None:  # a solid cell never changes
            out[:, self.solid] = 0.0
        if c.sources:
            out[:, ix, iy] += self.terms(w)[:, ix, iy]
        return out

    def rest_view(self, start: np.ndarray, t: float) -> np.ndarray:
        """The primitives of a step's initial state (at time t) as its rest decisions see
        them (RestRules.mark): a running inflow's ghost cells move at the inflow's
        speed whatever their thickness (RestRules._inlet_moves)."""
        c, lay = self.cfg, self.lay
        if not (self.projected and c.bc[0] == "inflow") or t > c.inflow_stop:
            return start
        _, u, _ = c.inflow_state(t)
        if not u > 0:
            return start
        out = start.copy()
        lo, hi = (0, lay.ny) if c.inflow_rows is None else c.inflow_rows
        ys = slice(lay.gy + lo, lay.gy + hi)
        still = out[lay.HU, : lay.gx, ys] == 0
        if not lay.is_1d:
            still &= out[lay.HV, : lay.gx, ys] == 0
        out[lay.HU, : lay.gx, ys] = np.where(still, u, out[lay.HU, : lay.gx, ys])
        return out

    def film_faces(self, Flo, Fhi, start, cell, lo, hi):
        """RestRules.film_faces on arrays: the fluxes Flo, Fhi through the low and
        high face of the cells ``cell`` (an index into the grid; ``lo``, ``hi`` index their
        neighbours) as those cells take them: no momentum into a film at rest at the step's
        start (primitives ``start``) from a neighbour at rest."""
        if not self.projected:
            return Flo, Fhi
        lay = self.lay
        still = ~self.moving(start)
        film = still & (start[lay.H] < self.cfg.h_min)
        zl = film[cell] & still[lo]
        zh = film[cell] & still[hi]
        Flo, Fhi = Flo.copy(), Fhi.copy()
        for m in (lay.HU,) if lay.is_1d else (lay.HU, lay.HV):
            Flo[m] = np.where(zl, 0.0, Flo[m])
            Fhi[m] = np.where(zh, 0.0, Fhi[m])
        return Flo, Fhi

    def postprocess(self, q: np.ndarray) -> None:
        """Stage limiter: h >= 0, no momentum where no source acts (`acts`), 0 <= h phi <= h."""
        lay = self.lay
        h = np.where(q[lay.H] < 0.0, 0.0, q[lay.H])  # NaN passes through to the guard
        q[lay.H] = h
        dry = ~self.acts(h)
        q[lay.HU][dry] = 0.0
        if not lay.is_1d:
            q[lay.HV][dry] = 0.0
        if lay.segregation:
            q[lay.HPHI] = np.clip(q[lay.HPHI], 0.0, h)
