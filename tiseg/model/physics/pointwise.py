"""Pointwise terms of (6.1)-(6.6) for one primitive state w = (h, u[, v][, phi]).

Every switch of the scene (segregation, 1D, friction law, mobility feedback) is a compile-time
constant read through ``ti.static``: a switched-off effect leaves no code in the kernels.
Run-time numbers (slope, friction constants, inflow, ...) live in one small parameter field so
they can change without recompiling.
"""

import taichi as ti

from ...taichi_classes import data_oriented

from .friction import FRICTION_LAWS
from .param_layout import ParamLayout
from .params import Params
from .segregation import TRANSPORTS
from .viscosity import VISCOSITY

__all__ = ["Physics", "Params", "slot_bases"]


def slot_bases(cfg) -> dict[str, int]:
    """Where each component's numbers start in the parameter field (`ParamLayout`: the
    transport's, the viscosity's, the friction law's, each source term's ...), and ``"end"``,
    the field's length. A component that is off has no slots."""
    lay = ParamLayout.of(cfg)
    return {**dict(lay.bases), "end": lay.end}


@data_oriented
class Physics:
    def __init__(self, cfg, par, params):
        """cfg: the OperatorConfig; par: the operator's parameter field, laid out by
        ``params`` (its `ParamLayout`: the components' slots from Params.COUNT on)."""
        lay = cfg.layout
        self.par = par
        self.nc = lay.nc
        self.is_1d = lay.is_1d
        self.seg = lay.segregation
        self.H, self.HU, self.HV, self.HPHI = lay.H, lay.HU, lay.HV, lay.HPHI
        bases = dict(params.bases)
        # the transport function G(phi) as a component (only with segregation)
        if self.seg:
            self._G, self._dG = TRANSPORTS[cfg.transport].taichi(ti, par, bases["transport"])
        # the viscosity (6.2) as a component (only with it): face coefficient, stresses and
        # the cell's stiffness bound
        self.visc = cfg.viscous
        if self.visc:
            fns = VISCOSITY.taichi(ti, par, bases["viscosity"], Params.H_MIN, not self.is_1d)
            self.face_K, self.normal_stress, self.shear_stress, self.visc_stiffness = fns
        # the friction law as a component: its Taichi functions read its own slots
        self.law = FRICTION_LAWS[cfg.friction]
        self.fr_none = cfg.friction == "none"
        # SPIR-V (Vulkan) has no 64-bit pow: the extended law's power is then taken in f32
        f32_pow = par.dtype == ti.f64 and ti.lang.impl.current_cfg().arch == ti.vulkan
        self._mu, self._mu_start = self.law.taichi(ti, par, bases["friction"], f32_pow)
        # compile-time switches as bools (ti.static does not take strings)
        self.feedback = cfg.feedback and lay.segregation and self.law.weighted
        # friction as a projection after each stage (project_friction) instead of a source
        self.fr_projected = cfg.friction_projected
        # films thinner than h_min flow (gravity, friction, momentum) in the split sweeps,
        # whose draining factors keep every cell's h >= 0; the unsplit scheme keeps the
        # paper's cut-off (section 6.2), see `acts`
        self.films = bool(cfg.split)
        self.fr_source = not self.fr_none and not self.fr_projected
        # a reference surface that bends (terrain.runout): gravity per column, and the
        # normal load g cos zeta + kappa u^2 (tiseg.solver.numerics.gravity)
        self.bend = cfg.bend is not None

    @ti.func
    def g0(self, e):
        """The plane's gravity (g sin zeta, g cos zeta, kappa = 0): the vector g the functions
        below take, which on a bend is the column's (tiseg.solver.numerics.gravity)."""
        gc = self.par[e, Params.G_COS]
        return ti.Vector([self.par[e, Params.G_SIN], gc, 0.0 * gc])

    @ti.func
    def g_normal(self, u, g):
        """The normal load per unit mass at the downslope velocity u: g cos zeta, plus on a
        bend the centripetal kappa u^2, clipped at zero (a convex bend taken fast unloads the
        bed: no pressure, no friction)."""
        r = g[1]
        if ti.static(self.bend):
            r = ti.max(g[1] + g[2] * u * u, 0.0)
        return r

    @ti.func
    def mu_g(self, e, h, spd, phi, gn):
        """mu_b under the normal load gn: a law's Froude number |u| / sqrt(g cos zeta h) is
        taken with the plane's g cos zeta (par), so on a bend the speed it sees is scaled to
        give |u| / sqrt(gn h) (gn floored: where it is 0 the friction is too)."""
        s = spd
        if ti.static(self.bend):
            gc = self.par[e, Params.G_COS]
            s = spd * ti.sqrt(gc / ti.max(gn, 1e-6 * gc))
        return self.mu_b(e, h, s, phi)

    @ti.func
    def vel(self, w, d: ti.template()):
        """Velocity component along direction d (0 = x, 1 = y)."""
        r = w[1]
        if ti.static(d == 1):
            r = w[self.HV]
        return r

    @ti.func
    def G(self, e, phi):
        """The scene's transport function, (2.17) or (2.18) (tiseg.model.physics.segregation)."""
        return self._G(e, phi)

    @ti.func
    def dG(self, e, phi):
        return self._dG(e, phi)

    @ti.func
    def conserved(self, w):
        q = w
        for c in ti.static(range(1, self.nc)):
            q[c] = w[c] * w[0]
        return q

    @ti.func
    def flux(self, e, w, d: ti.template(), g):
        """Physical flux of (6.1)-(6.3) along d: mass, momentum with slope-normal pressure
        (1/2) g cos(zeta) h^2 (on a bend (1/2) (g cos zeta + kappa u^2) h^2, `g_normal`), and
        the large-particle transport h u (phi - G(phi)). g: (g sin zeta, g cos zeta, kappa) of
        the face (`g0` on a plane)."""
        h = w[0]
        half_gn = 0.5 * self.g_normal(w[1], g)
        vn = self.vel(w, d)
        f = ti.Vector.zero(float, self.nc)
        f[0] = h * vn
        f[1] = h * w[1] * vn
        if ti.static(not self.is_1d):
            f[self.HV] = h * w[self.HV] * vn
        if ti.static(d == 0):
            f[1] += half_gn * h * h
        else:
            f[self.HV] += half_gn * h * h
        if ti.static(self.seg):
            phi = w[self.HPHI]
            f[self.HPHI] = h * vn * (phi - self.G(e, phi))
        return f

    @ti.func
    def speed(self, e, w, d: ti.template(), g):
        """Local characteristic speed: max(|u| + sqrt(g h cos zeta), |u (1 - G'(phi))|)
        (5.25)-(5.26); on a bend sqrt(gn h) + |kappa| h |u| in place of sqrt(g h cos zeta),
        a bound of the waves of the pressure (1/2) (g cos zeta + kappa u^2) h^2."""
        vn = self.vel(w, d)
        a = ti.abs(vn) + self.wave(w, g)
        if ti.static(self.seg):
            a = ti.max(a, ti.abs(vn * (1.0 - self.dG(e, w[self.HPHI]))))
        return a

    @ti.func
    def wave(self, w, g):
        """The gravity wave's speed relative to the flow: sqrt(g cos zeta h), on a bend
        sqrt(gn h) + |kappa| h |u| (`speed`)."""
        c = ti.sqrt(g[1] * w[0])
        if ti.static(self.bend):
            c = ti.sqrt(self.g_normal(w[1], g) * w[0]) + ti.abs(g[2] * w[0] * w[1])
        return c

    @ti.func
    def speed_range(self, e, w, d: ti.template(), g):
        """Smallest and largest characteristic speed along d, (u - c, u + c) widened to take in
        the segregation speed u (1 - G'(phi)) (5.26): the one-sided local speeds of the
        central-upwind flux."""
        vn = self.vel(w, d)
        c = self.wave(w, g)
        lo = vn - c
        hi = vn + c
        if ti.static(self.seg):
            s = vn * (1.0 - self.dG(e, w[self.HPHI]))
            lo = ti.min(lo, s)
            hi = ti.max(hi, s)
        return ti.Vector([lo, hi])

    @ti.func
    def transported(self, e, phi):
        """phi - G(phi): the large-particle flux per unit mass flux, h u (phi - G) / (h u).
        Non-decreasing in phi for every transport function (1 - G' >= alpha with (2.17),
        >= 0 with (2.18)), so upwinding phi by the sign of the mass flux is upwinding this
        flux."""
        return phi - self.G(e, phi)

    @ti.func
    def _weight(self, e, phi):
        """The concentration a mixture law weights with: the local phi with mobility
        feedback, else flow.phi0."""
        ph = self.par[e, Params.PHI_REF]
        if ti.static(self.feedback):
            ph = phi
        return ph

    @ti.func
    def mu_b(self, e, h, spd, phi):
        """Basal friction coefficient of the scene's law at thickness h and speed spd
        (tiseg.model.physics.friction); phi weights a mixture (3.4) with mobility feedback, else
        flow.phi0 does."""
        return self._mu(e, h, spd, self._weight(e, phi))

    @ti.func
    def mu_start(self, e, h, phi):
        """The largest coefficient at rest: mu_S(h) of a law with hysteresis, else mu_b at
        zero speed."""
        return self._mu_start(e, h, self._weight(e, phi))

    @ti.func
    def speed_mag(self, w):
        """|(w[1], w[HV])|: the speed of a primitive state, |h u| of a conserved one."""
        s = ti.abs(w[1])
        if ti.static(not self.is_1d):
            s = ti.sqrt(w[1] * w[1] + w[self.HV] * w[self.HV])
        return s

    @ti.func
    def acts(self, e, h):
        """Whether the sources and the friction act on a cell of thickness h: wherever there
        is material in the split sweeps (films flow), only where h >= h_min in the unsplit
        scheme. There the paper's cut-off stays: RKC's stages are not positivity
        preserving, and films that moved under them were emptied below zero, the clip then
        creating mass (3e-6 of a finite release's in ten steps). (Cutting the films off at
        h_eps instead of 0 coarsened the parabolic cap's margins: L1 5.6e-4 against 2.4e-4
        at 1000 cells.)"""
        out = h >= self.par[e, Params.H_MIN]
        if ti.static(self.films):
            out = h > 0.0
        return out

    @ti.func
    def film_h(self, e, h):
        """The thickness a friction law is evaluated at: h, or h_min in a film thinner than
        that (the laws' thickness dependence (3.7) describes layers many grains deep, and
        0 / 0 at h = 0 is avoided)."""
        return ti.max(h, self.par[e, Params.H_MIN])

    @ti.func
    def source(self, e, w, g):
        """g h S of (6.4): gravity along the slope and basal friction opposing the motion, with
        u/|u| regularised as u / max(|u|, u_eps). With the projected friction scheme the
        friction is left to project_friction. g: the cell's (g sin zeta, g cos zeta, kappa);
        the friction is that of the normal load `g_normal`.

        In the split sweeps it acts in films thinner than h_min as well (`acts`): a film is
        flow, whose momentum the stage limiter keeps. Cutting the film's source and momentum
        off (the paper's h_min rule, section 6.2) made every front thin to h_min before it
        could advance: fronts ran a quarter slow at h_min / h0 = 1/30 (docs/verification.md,
        "Fronts")."""
        h = w[0]
        s = ti.Vector.zero(float, self.nc)
        if self.acts(e, h):
            s[1] = h * g[0]
            if ti.static(self.fr_source):
                spd = self.speed_mag(w)
                phi = self.par[e, Params.PHI_REF]
                if ti.static(self.seg):
                    phi = w[self.HPHI]
                gn = self.g_normal(w[1], g)
                mu = self.mu_g(e, self.film_h(e, h), spd, phi, gn)
                inv = 1.0 / ti.max(spd, self.par[e, Params.U_EPS])
                s[1] = h * (g[0] - gn * mu * w[1] * inv)
                if ti.static(not self.is_1d):
                    s[self.HV] = -h * gn * mu * w[self.HV] * inv
        return s

    @ti.func
    def friction_rate(self, e, w, g):
        """Stiffness of the friction term, g cos(zeta) mu_b / max(|u|, u_eps) [1/s]; zero when
        the friction is projected (it is then no part of the explicit stages)."""
        r = 0.0 * w[0]
        if ti.static(self.fr_source):
            h = w[0]
            if self.acts(e, h):
                spd = self.speed_mag(w)
                phi = self.par[e, Params.PHI_REF]
                if ti.static(self.seg):
                    phi = w[self.HPHI]
                gn = self.g_normal(w[1], g)
                r = (
                    gn
                    * self.mu_g(e, self.film_h(e, h), spd, phi, gn)
                    / ti.max(spd, self.par[e, Params.U_EPS])
                )
        return r

    @ti.func
    def _phi_of(self, e, q, h):
        phi = self.par[e, Params.PHI_REF]
        if ti.static(self.seg):
            phi = ti.min(ti.max(q[self.HPHI] / h, 0.0), 1.0)
        return phi

    @ti.func
    def project_friction(self, e, q, tau, spd0, hb, g):
        """Basal friction over the time tau as a projection of the conserved state q (friction
        scheme "projected"; Mangeney et al. 2007, J. Geophys. Res. 112, F02017, after Bouchut
        et al. 2003). The friction impulse per unit area is I = tau g cos(zeta) mu_b h. Where
        |h u| <= I the friction can cancel the momentum and the cell stops exactly (u = 0);
        otherwise the momentum shrinks by I along its own direction. This needs no
        regularisation of u / |u| and is no stiff term for the stepper; it never reverses the
        flow and leaves h and h phi alone.

        mu_b is the scene's law at ``spd0``, the cell's speed in the state the stage started
        from: the coefficient lags by one stage. A steady uniform flow, whose gravity impulse
        per stage equals I at its own speed, is then kept to round-off. Taken at the speed of
        q, which is the speed before friction, a law whose coefficient grows with the speed
        (3.7) gave an impulse too large by O(tau): it slowed steady flows and stopped a layer
        it could not hold when the step was long. Whether a law with hysteresis holds a cell
        at rest is decided once per step, by `holds`; a cell it holds is not projected
        (the operator keeps it at rest).

        ``hb``: the thickness the impulse acts on, tau g cos(zeta) mu_b hb: the one the
        gravity of the same time acted on (q's own h after an Euler stage; the trapezoidal
        mean of the thickness before and after a split sweep's fluxes). Friction and gravity
        are then one source h g (sin(zeta) - cos(zeta) mu_b) integrated alike; with q's h
        where the sweep's gravity took the mean, a cell that filled during the step felt the
        friction of its whole new mass against the gravity of half of it, and a front
        sliding under Coulomb friction lagged (Mangeney et al. 2000: 8 m in 97 m).

        In the split sweeps films thinner than h_min are projected too (they move: see
        `source`), with the coefficient of a layer h_min thick, as the source takes it
        (`film_h`). g: the cell's gravity; on a bend the normal load is taken at q's velocity."""
        r = q
        h = q[0]
        if self.acts(e, h) and tau > 0:
            m = self.speed_mag(q)  # |h u| of the conserved state
            phi = self._phi_of(e, q, h)
            gn = self.g_normal_q(q, h, g)
            imp = tau * gn * self.mu_g(e, self.film_h(e, h), spd0, phi, gn) * hb
            f = 0.0 * h
            if m > imp:
                f = 1.0 - imp / m
            r[1] = f * q[1]
            if ti.static(not self.is_1d):
                r[self.HV] = f * q[self.HV]
        return r

    @ti.func
    def g_normal_q(self, q, h, g):
        """`g_normal` at the velocity of the conserved state q (h > 0)."""
        u = 0.0 * h
        if ti.static(self.bend):
            u = q[1] / h
        return self.g_normal(u, g)

    @ti.func
    def holds(self, e, q, tau, g):
        """1 where the static friction holds a cell that was at rest at the step's start (a
        law with hysteresis), else 0. Called on the step's first stage, which is one Euler
        step of length tau from the step's initial state Y0 for every stepper, so the
        stage's momentum is tau f(Y0), f the force per unit area of gravity, pressure and
        stress on the resting cell: the cell is held where |f(Y0)| <= g cos(zeta) mu_S(h) h,
        a test of the initial state alone, whatever the step length, the stepper or its
        stage count. A held cell stays exactly at rest for the whole step; one that is not
        held starts and feels the friction of project_friction (at rest, the law's
        coefficient at zero speed: mu_S(h) for the extended law). A film is held as a layer
        h_min thick would be (`film_h`)."""
        r = 0
        h = q[0]
        if self.acts(e, h) and tau > 0:
            m = self.speed_mag(q)  # |h u| of the conserved state
            mu = self.mu_start(e, self.film_h(e, h), self._phi_of(e, q, h))
            if m <= tau * self.g_normal_q(q, h, g) * mu * h:
                r = 1
        return r
