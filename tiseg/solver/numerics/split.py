"""Dimensionally split MUSCL-Hancock sweeps (``numerics.stepper = "hancock"``).

A step of the split scheme is one sweep per direction, each a complete one-stage
finite-volume update of its own: where the semi-discrete operator (`operator`) is
integrated by Runge-Kutta stages that each need the fluxes of both directions, a sweep moves
the state a whole step along one direction from a single flux evaluation. Along direction d
(spacing D, lambda = dt / D), on the cells' primitives w:

1. the limited slopes s of the operator (`FiniteVolume.slope`: minmod-theta or the
   WENO-type slope, with h >= 0 and 0 <= phi <= 1 at the edges);
2. the edge states w -+ s/2, conserved q_W, q_E, evolved half a step by the cell's own flux
   difference (Hancock's predictor; van Leer 1984, Toro 2009 section 14.4):

       q~_W,E = q_W,E - lambda/2 (f(q_E) - f(q_W)) + dt/2 S(w)

   where the predicted h of either edge would be negative the cell keeps its unevolved edges
   (first order in time there: the predictor is a Taylor step and knows nothing of dry beds);
3. the numerical flux of the operator (``numerics.flux``: central-upwind = HLL with the local
   one-sided speeds, or KT; ``phi_flux`` upwind) between q~_E of a cell and q~_W of its
   neighbour, zero between two films thinner than h_min;
4. the draining-time correction (Bollermann, Chen, Kurganov & Noelle 2013, J. Sci. Comput. 56,
   267): a cell whose outgoing mass lambda (F+_h + F-_h) exceeds its h gives out only h, every
   component of the flux through a face being scaled by theta = h / outgoing of the cell the
   mass leaves; with segregation the same for its small particles (h phi) and its large ones
   (h (1 - phi)), theta the smallest of the three. So h >= 0 and 0 <= phi <= 1 after any step
   that the scheme's stability allows, not only below a positivity bound, and the scaling is
   conservative (a face's flux is one number for both cells). (phi_flux "upwind", which the
   scene requires with segregation here, makes the three fluxes of a face run the same way,
   so the factor of the cell the mass leaves is the one all three need);
5. q := q - lambda (F_{m+1/2} - F_{m-1/2}) + dt S, the source (gravity along the slope,
   g sin(zeta) h; the friction is projected, below) in the x sweep only, by the trapezoidal
   rule between the h before and after the fluxes, and the scene's source terms beyond (6.4)
   (`source_terms.SourceTerms`) over the whole step at their rate in the sweep's initial
   state, which the predictor also takes for its half step (forward Euler in the update: a
   term whose rate has a stiffness bound r limits the step to dt <= cfl / r,
   `tiseg.run.simulation`); then the stage limiter (phi in [0, 1], no momentum in films
   thinner than h_min).

The sweeps alternate their order from step to step (x then y, then y then x), which makes the
splitting error of two steps second order (Strang 1968) at two sweeps a step; each sweep is
stable for Courant numbers up to 1 (``numerics.cfl``, with step_rule "max": dt = cfl min(dx/a_x,
dy/a_y)), against 1/2 for a_x dt/dx + a_y dt/dy of the unsplit scheme's Euler steps. A sweep
costs about 0.7 of an evaluation of the operator (benchmarks/README.md section 7).

The basal friction (6.4) is the projected one (Physics.project_friction; numerics.friction_scheme
"projected"), in three places:

* the x predictor projects each evolved edge over dt/2 at its cell's speed, so that the
  half-step edges see the friction with the gravity it balances;
* the first sweep of a step takes the step's rest mask (RestRules.mark): no mass or
  h phi crosses a face between two cells at rest at the step's start, and such a face's flux
  is computed with both edges' velocities zero (the momentum a sweep gives a resting cell is
  not yet frictioned, and the flux's dissipation would trade it between the next sweep's
  cells); the flux floor of a cell moving into a slower one applies as in the unsplit scheme;
* the last sweep projects the friction of the whole step, over dt, at each cell's speed at
  the step's start (RestRules.project). The hold then sees the whole step's driving
  (gravity, pressure along x and along y), and the steady uniform flow (4.3) is kept to
  round-off whichever sweep comes first. A projection after each sweep would see one
  direction's driving at a time and could release in y a cell held in x.

Segregation and the mobility feedback need nothing more: the h phi flux is upwinded by the
mass flux, and the mixture law weights with the cell's phi inside the projection. An inflow's
ghost cells hold its state at mid-step (t + dt/2), the time of the edges they face.

The viscous stress of (6.2) is a third operator V: with viscosity a step of dt is the
symmetric pair of half steps x(dt/2) y(dt/2) | V(dt) | y(dt/2) x(dt/2) (x | V | x in 1D),
Strang's splitting, so the splitting error is second order. V (`viscous_substep.ViscousSubstep`) moves only
the momenta: the divergence of the unsplit operator's
viscous face stresses (FiniteVolume.x_viscous, y_viscous: harmonic face coefficients,
cross derivatives over four cells), integrated by s RKC stages (the stepper,
tiseg.solver.timestepping.split, picks s from dt rho_visc as RKC does, at least 2), so the
step stays the convective one where the explicit viscous limit is shorter. The stages are
summed as increments, Y_j = Y0 + (mu (Y_j-1 - Y0) + nu (Y_j-2 - Y0) + ...), so a cell whose
viscous rates are zero at every stage keeps its bits (rest among rest, a uniform flow) and
h and h phi are never touched. The friction projection closes each half over dt/2, after
its last sweep, with the rest mask and speeds of the half's initial state (taken by the
first sweep, or by V, which opens the second half), so the hold sees its half's driving,
the viscous force included in the second. Through a running inlet V takes no stress
(`_inlet_velocities`). Chosen by measurement (docs/numerics.md, "Viscosity"): on a smooth
2D flow the pair is second order and as accurate as two steps x, y, V and V, y, x with a V of
dt/2 each, at one stability pass and s(dt) ~ sqrt(2) s(dt/2) viscous stages instead of two
passes and 2 s(dt/2) stages; viscous fluxes inside the sweeps would see the cross terms only
lagged (first order in time) and would bind the step to the explicit viscous limit.

A scene with the regularised friction must use the Runge-Kutta steppers (the scene says so
when it is read). The NumPy twins are `tiseg.solver.reference.split.hancock_sweep`,
`tiseg.solver.reference.split.viscous_substep`, `tiseg.solver.reference.split.hancock_step`
and, with viscosity, `tiseg.solver.reference.split.hancock_pair`.
"""

import numpy as np
import taichi as ti

from ...taichi_classes import data_oriented
from ...model.physics.pointwise import Params


@data_oriented
class SplitSweeps:
    """The sweeps of the split scheme (its viscous sub-step: `viscous_substep.ViscousSubstep`)."""

    def __init__(self, state, ghosts, fv, rules):
        """``state``: the operator's fields, slots and ranges (`state.OperatorState`: ``w``,
        ``q``, ``fx``/``fy``, the edge fields ``ew``/``ee`` and the draining factors ``drain``,
        which only a split scene allocates); ``ghosts``: its ghost cells
        (`ghosts.GhostCells`); ``fv``: the evaluation of L whose slopes, numerical fluxes,
        and limiter the sweeps use (`finite_volume.FiniteVolume`);
        ``rules``: the projected friction's face rules and projection (`rest.RestRules`)."""
        self.state = state
        self.ghosts = ghosts
        self.fv = fv
        self.rules = rules

    def sweep(self, d: int, t, dt, first: bool = True, last: bool = True) -> None:
        """One sweep along d (0 = x, 1 = y) of slot 0 over dt from time t: ghost cells (an
        inflow's at t + dt/2), the update of the active range in place, its boundary fluxes
        into slot 0's budget. In a batch t and dt may be one per member (each running member
        takes its own sweep).
        ``first``, ``last``: the sweep opens or closes its step (both in 1D). With the
        projected friction the first sweep takes the step's rest mask and initial speeds,
        and the last one projects the friction of the whole step."""
        if d == 0 and self.state.bc[0] == "periodic":
            # the ghosts' draining factors are copied from the edge cells, which the factor
            # pass computes only on the active range (the simulation keeps it whole then)
            assert self.state.active == (self.state.gx, self.state.gx + self.state.nx), (
                "periodic x: whole range"
            )
        fr = self.state.phys.fr_projected
        if fr and first:
            self.fv.prepare(0, t)  # the rest mask of the step's initial state (if not taken)
        # an inflow's ghost cells hold its state at mid-step, the time of the predicted edges
        # they face (the ramp of (6.8) to second order; a step that begins when the inflow
        # stops sees a wall); other ghost cells do not depend on the time
        tg = t + 0.5 * dt if self.state.bc[0] == "inflow" else t
        self.state.set_time(tg)
        # what the last preparation left valid in w: everything (a stability pass at tg on
        # slot 0), the interior (the last sweep, or a stability pass at another time), or
        # nothing
        fresh = self.state.fresh(0, tg)
        lam = (np.asarray(dt) if self.state.batched else dt) / (
            self.state.cfg.dx if d == 0 else self.state.cfg.dy
        )
        # compile-time flags only where they change the code: with the projected friction
        first, last = bool(fr and first), bool(fr and last)
        hold = self.state.first_of_step(True) if last else False
        if self.state.batched:  # each member's lambda and dt, read by the kernel
            self.state.put_numbers({0: lam, 1: dt})
            lam, dt = 0.0, 0.0
        self._sweep(d, fresh, float(lam), float(dt), first, last, hold, self.state.serial_loops())
        self.state.written(0, primitives=True)

    @ti.kernel
    def _sweep(
        self,
        d: ti.template(),
        fresh: ti.template(),
        lam: float,
        dt: float,
        first: ti.template(),
        last: ti.template(),
        hold: ti.template(),
        serial: ti.template(),
    ):
        """Sweep along d in one launch (top-level loops run in order): ghosts and primitives
        as far as ``fresh`` says they are stale, the predicted edges, the face fluxes, the
        draining factors, the update with its budget (with the friction projection of the
        step if ``last``; ``hold``: a law with hysteresis decides which cells it holds)."""
        if ti.static(fresh < 2):
            self.ghosts.fill(0)
            if ti.static(fresh == 1):
                self.fv.edge_primitives(0, serial)
            else:
                self.fv.primitives(0, serial)
        self._predict(d, lam, dt, serial)
        self._sweep_faces(d, serial)
        self._drain_factors(d, lam, serial)
        self._sweep_update(d, lam, dt, first, last, hold, serial)

    # -------------------------------------------------------------- index helpers
    @ti.func
    def _nb(self, i, j, d: ti.template(), k):
        """The cell k cells along d from (i, j)."""
        ii, jj = i, j
        if ti.static(d == 0):
            ii = i + k
        else:
            jj = j + k
        return ii, jj

    # -------------------------------------------------------------- the passes
    @ti.func
    def _predict(self, d: ti.template(), lam, dt, serial: ti.template()):
        """Hancock's predicted edge states of every cell a face of this sweep reads, as
        primitives: west/south edge in ew, east/north edge in ee."""
        gy, ny = ti.static(self.state.gy, self.state.ny)
        a, b = self.state.act[0], self.state.act[1]
        ph = self.state.phys
        ilo, ihi, jlo, jhi = a, b, gy, gy + ny
        if ti.static(d == 0):
            ilo, ihi = ti.max(a - 1, 1), ti.min(b + 1, self.state.NX - 1)
        else:
            jlo, jhi = gy - 1, gy + ny + 1
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange((ilo, ihi), (jlo, jhi), self.state.M):
            lam_e = self.state.number(e, 0, lam)
            dt_e = self.state.number(e, 1, dt)
            w0 = self.state.w[i, j, e]
            s = w0 * 0.0
            if ti.static(not self.state.rec_first):
                im, jm = self._nb(i, j, d, -1)
                ip, jp = self._nb(i, j, d, 1)
                s = self.fv.slope(e, self.state.w[im, jm, e], w0, self.state.w[ip, jp, e])
            wW = w0 - 0.5 * s
            wE = w0 + 0.5 * s
            qW = ph.conserved(wW)
            qE = ph.conserved(wE)
            g = self.state.grav.cell(e, i)  # (its edges' gravity: the cell's)
            shift = (0.5 * lam_e) * (ph.flux(e, wE, d, g) - ph.flux(e, wW, d, g))
            keep = 0  # 1: the edges stay unevolved
            if ti.static(d == 0):
                sgn, keep = self._ghost_source(e, i)
                src = ph.source(e, w0, g)
                if ti.static(self.state.terms.on):
                    # the scene's terms, from the sweep's initial state: half a step here,
                    # the whole step in the update (kept for it)
                    rate = self.state.terms.rate(e, i, j)
                    self.state.srate[i, j, e] = rate
                    src += rate
                shift -= (0.5 * dt_e * sgn) * src
            if ti.static(self.fv.has_bed):  # the bed's pull (tiseg.solver.numerics.bed)
                shift[1 if d == 0 else self.state.HV] -= self.fv.bed.predicted(
                    e, i, j, d, wW[0], wE[0], dt_e
                )
            pW = qW - shift
            pE = qE - shift
            if pW[0] < 0.0 or pE[0] < 0.0 or keep == 1:  # the predictor would empty an edge
                pW = qW
                pE = qE
            elif ti.static(d == 0 and ph.fr_projected):
                # the friction of the half step with the gravity it balances: the projection
                # of each edge over dt/2 at the cell's speed (Physics.project_friction)
                spd = ph.speed_mag(w0)
                pW = ph.project_friction(e, pW, 0.5 * dt_e, spd, pW[0], g)
                pE = ph.project_friction(e, pE, 0.5 * dt_e, spd, pE[0], g)
            self.state.ew[i, j, e] = self.fv.fast_primitive(e, pW)
            self.state.ee[i, j, e] = self.fv.fast_primitive(e, pE)

    @ti.func
    def _ghost_source(self, e, i):
        """(sign of the source, keep as 0 or 1) in the x predictor of cell column i.
        Interior, outflow and periodic ghost cells evolve as the cells they copy (+1). A
        wall's ghost cell is the mirror image of its interior cell, so its source is mirrored
        too (-1): the
        predicted edges on both sides of the wall then mirror each other and no mass crosses
        it (with +1 the gravity source pushed mass through a wall on a slope). An inflow's
        ghost cells hold the prescribed state, which is not evolved (keep = 1); a stopped
        inflow is a wall."""
        gx, nx = ti.static(self.state.gx, self.state.nx)
        # the components' kinds as compile-time bools (ti.static takes no objects)
        lo_mirrors, lo_prescribed = ti.static(
            self.state.bcs[0].mirrors, self.state.bcs[0].prescribed
        )
        hi_mirrors = ti.static(self.state.bcs[1].mirrors)
        sgn = 1.0
        keep = 0
        if i < gx:
            if ti.static(lo_mirrors):
                sgn = -1.0
            elif ti.static(lo_prescribed):
                if self.state.par[e, Params.IN_ON] > 0.5:
                    keep = 1
                else:
                    sgn = -1.0
        elif i >= gx + nx:
            if ti.static(hi_mirrors):
                sgn = -1.0
        return sgn, keep

    @ti.func
    def _sweep_faces(self, d: ti.template(), serial: ti.template()):
        """Numerical fluxes between the predicted edges: the face (m, m + 1) along d at m's
        index, in fx (d = 0) or fy (d = 1); zero between two films thinner than h_min at rest
        (FiniteVolume.face_wet)."""
        gy, ny = ti.static(self.state.gy, self.state.ny)
        a, b = self.state.act[0], self.state.act[1]
        ilo, ihi, jlo, jhi = a, b, gy, gy + ny
        if ti.static(d == 0):
            ilo = a - 1
        else:
            jlo = gy - 1
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange((ilo, ihi), (jlo, jhi), self.state.M):
            hmin = self.state.par[e, Params.H_MIN]
            i1, j1 = self._nb(i, j, d, 1)
            F = ti.Vector.zero(self.state.fp, self.state.nc)
            wl = self.state.ee[i, j, e]
            wr = self.state.ew[i1, j1, e]
            wet = self.fv.face_wet(
                e, self.state.w[i, j, e], self.state.w[i1, j1, e], hmin, i, j, i1, j1
            )
            fluid = True  # (not a wall: tiseg.solver.numerics.walls; h* over a bed)
            if ti.static(self.fv.terrain):
                wl, wr, wet, fluid = self.fv.sweep_terrain(e, i, j, i1, j1, d, wl, wr, wet)
            if wet:
                if ti.static(self.state.phys.fr_projected):
                    if self.rules.both_at_rest(e, i, j, i1, j1):
                        # two cells at rest at the step's start meet with no velocity: the
                        # momentum a sweep gave them is not yet frictioned, and the flux's
                        # dissipation would trade it between them (the friction's hold must
                        # see the driving of the step's initial state, as the unsplit
                        # scheme's first stage does)
                        wl = self.rules.still(wl)
                        wr = self.rules.still(wr)
                F = self.fv.face_flux(e, wl, wr, d, self.state.grav.face(e, i, d))
                # the projected friction's face rules, from the step's rest mask
                if ti.static(not self.fv.terrain):
                    F = self.rules.rest_face(e, F, wl, wr, d, i, j, i1, j1)
                elif fluid:
                    F = self.rules.rest_face(e, F, wl, wr, d, i, j, i1, j1)
            if ti.static(d == 0):
                self.state.fx[i, j, e] = F
            else:
                self.state.fy[i, j, e] = F

    @ti.func
    def _across(self, d: ti.template()):
        """The range [lo, hi) of cells across d that a sweep along d updates: the interior
        rows in x, the active columns in y."""
        lo, hi = self.state.gy, self.state.gy + self.state.ny
        if ti.static(d == 1):
            lo, hi = self.state.act[0], self.state.act[1]
        return lo, hi

    @ti.func
    def _along(self, d: ti.template(), m, k):
        """The cell (i, j) at index m along d and k across it."""
        i, j = m, k
        if ti.static(d == 1):
            i, j = k, m
        return i, j

    @ti.func
    def _face(self, e, i, j, d: ti.template()):
        F = self.state.fx[i, j, e]
        if ti.static(d == 1):
            F = self.state.fy[i, j, e]
        return F

    @ti.func
    def _drain_factors(self, d: ti.template(), lam, serial: ti.template()):
        """drain := each updated cell's factor: 1, or what it holds / what would leave it over
        the step where that is less, the smallest of that ratio for h and, with segregation,
        for h phi and h (1 - phi); 1 on the cells next to them that the sweep leaves as they
        are (ghosts, cells beyond the active range), except that a periodic boundary's ghost
        cells take their images' factors. A pass of its own: the update must read its
        neighbours' factors, computed from their h before the update."""
        gy, ny = ti.static(self.state.gy, self.state.ny)
        a, b = self.state.act[0], self.state.act[1]
        ilo, ihi, jlo, jhi = a, b, gy, gy + ny
        if ti.static(d == 0):
            ilo, ihi = a - 1, b + 1
        else:
            jlo, jhi = gy - 1, gy + ny + 1
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange((ilo, ihi), (jlo, jhi), self.state.M):
            lam_e = self.state.number(e, 0, lam)
            th = 1.0 + 0.0 * lam_e
            inside = a <= i < b
            if ti.static(d == 1):
                inside = gy <= j < gy + ny
            if inside:
                im, jm = self._nb(i, j, d, -1)
                Fp = self._face(e, i, j, d)
                Fm = self._face(e, im, jm, d)
                q0 = self.state.q[0, i, j, e]
                out = lam_e * (ti.max(Fp[0], 0.0) - ti.min(Fm[0], 0.0))
                if out > q0[0]:
                    th = q0[0] / out
                if ti.static(self.state.seg):
                    # the small particles (h phi) and the large ones (h (1 - phi)) of the cell
                    # as well: phi then stays in [0, 1] without the limiter's clip, which
                    # would create or destroy particles (with phi_flux "upwind" all three
                    # fluxes of a face run the same way, so one factor serves the face)
                    P = ti.static(self.state.HPHI)
                    out_s = lam_e * (ti.max(Fp[P], 0.0) - ti.min(Fm[P], 0.0))
                    if out_s * th > q0[P]:
                        th = q0[P] / out_s
                    out_l = lam_e * (ti.max(Fp[0] - Fp[P], 0.0) - ti.min(Fm[0] - Fm[P], 0.0))
                    if out_l * th > q0[0] - q0[P]:
                        th = (q0[0] - q0[P]) / out_l
            self.state.drain[i, j, e] = th
        # across a periodic boundary the ghost cell is its image: the face there is one face
        # of two cells, so both must scale it by the same factor (else mass is made or lost)
        if ti.static(self.state.bcs[2 * d].periodic):
            lo, hi = self._across(d)
            ti.loop_config(serialize=self.state.strip_serial)  # a column or a row of cells
            for k, e in ti.ndrange((lo, hi), self.state.M):
                self._periodic_image(e, d, k)

    @ti.func
    def _periodic_image(self, e, d: ti.template(), k):
        """The draining factors of member e's two ghost cells at index k across d from
        their images."""
        g, n = ti.static(
            (self.state.gx, self.state.nx) if d == 0 else (self.state.gy, self.state.ny)
        )
        i0, j0 = self._along(d, g - 1, k)
        i1, j1 = self._along(d, g + n - 1, k)
        self.state.drain[i0, j0, e] = self.state.drain[i1, j1, e]
        i0, j0 = self._along(d, g + n, k)
        i1, j1 = self._along(d, g, k)
        self.state.drain[i0, j0, e] = self.state.drain[i1, j1, e]

    @ti.func
    def _gravity(self, h, g):
        """g sin(zeta) h (Physics.source without friction; films included), g the cell's
        gravity (tiseg.solver.numerics.gravity)."""
        return h * g[0]

    @ti.func
    def _scaled(self, F, th_lo, th_hi):
        """A face's flux scaled by the draining factor of the cell its mass leaves."""
        out = F
        if F[0] > 0.0:
            out = th_lo * F
        elif F[0] < 0.0:
            out = th_hi * F
        return out

    @ti.func
    def _sweep_update(
        self,
        d: ti.template(),
        lam,
        dt,
        first: ti.template(),
        last: ti.template(),
        hold: ti.template(),
        serial: ti.template(),
    ):
        """q := q - lambda (F_{m+1/2} - F_{m-1/2}) with the fluxes scaled by the draining
        factors (+ the gravity source in the x sweep), limited, with its primitives into w;
        then the boundary fluxes of the sweep times dt into slot 0's budget. With the
        projected friction: the first sweep of a step keeps the initial speeds (2D), the
        last one projects the friction over the whole step at those speeds (RestRules.project,
        where ``hold`` lets a law with hysteresis hold the cells at rest)."""
        gx, nx, gy, ny = ti.static(self.state.gx, self.state.nx, self.state.gy, self.state.ny)
        fr = ti.static(first or last)  # (the projected friction: a sweep that opens or closes)
        a, b = self.state.act[0], self.state.act[1]
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange((a, b), (gy, gy + ny), self.state.M):
            if self.state.live(e):  # (a batch's finished members keep their state)
                lam_e = self.state.number(e, 0, lam)
                dt_e = self.state.number(e, 1, dt)
                im, jm = self._nb(i, j, d, -1)
                ip, jp = self._nb(i, j, d, 1)
                th = self.state.drain[i, j, e]
                Fp = self._scaled(self._face(e, i, j, d), th, self.state.drain[ip, jp, e])
                Fm = self._scaled(self._face(e, im, jm, d), self.state.drain[im, jm, e], th)
                if ti.static(self.state.phys.fr_projected):
                    Fm, Fp = self.rules.film_faces(e, Fm, Fp, i, j, im, jm, ip, jp)
                q0 = self.state.q[0, i, j, e]
                upd = -lam_e * (Fp - Fm)
                if ti.static(self.fv.has_bed):  # the bed's pressure (tiseg.solver.numerics.bed)
                    upd[1 if d == 0 else self.state.HV] += self.fv.bed.sweep_rate(
                        e, i, j, im, jm, d, lam_e, dt_e
                    )
                hg = 0.0 * dt_e  # the mean thickness gravity acted on over the step
                if ti.static(d == 0):
                    # gravity along the slope, h g sin(zeta) (the only source without friction),
                    # by the trapezoidal rule between the cell's h before and after the fluxes
                    h1 = q0[0] + upd[0]
                    g = self.state.grav.cell(e, i)
                    upd[1] += (0.5 * dt_e) * (self._gravity(q0[0], g) + self._gravity(h1, g))
                    if ti.static(self.state.terms.on):  # the scene's terms (from the predictor)
                        upd += dt_e * self.state.srate[i, j, e]
                    if ti.static(fr):
                        hg = 0.5 * (q0[0] + h1)
                        if ti.static(not last):
                            self.state.hg[i, j, e] = hg  # for the friction of the step's last sweep
                elif ti.static(last and not first):
                    hg = self.state.hg[i, j, e]  # (written by the step's x sweep)
                acc = self.fv.limit(e, q0 + upd)
                if ti.static(d == 1 and first and last):
                    hg = acc[0]  # a lone y sweep: no gravity acted, the friction on the cell's h
                if ti.static(first or last):
                    spd0 = 0.0 * dt_e
                    if ti.static(first):
                        spd0 = self.state.phys.speed_mag(
                            self.state.w[i, j, e]
                        )  # (w: the step's initial state)
                        if ti.static(not last):
                            self.state.spd0[i, j, e] = spd0
                    else:
                        spd0 = self.state.spd0[i, j, e]
                    if ti.static(last):
                        # the friction acts on the thickness the gravity acted on
                        acc = self.rules.project(e, acc, dt_e, i, j, hold, spd0, hg)
                if ti.static(self.fv.has_solid):  # a solid cell never changes
                    if self.fv.walls.is_solid(i, j):
                        acc = q0
                self.state.w[i, j, e] = self.fv.fast_primitive(e, acc)
                self.state.q[0, i, j, e] = acc
        # the budget: what entered through the domain's faces along d (as boundary_rates;
        # along x a face beyond the active range carried no flux this time)
        g, n = ti.static((gx, nx) if d == 0 else (gy, ny))
        wl = 1.0
        wr = 1.0
        if ti.static(d == 0):
            wl = ti.select(a == gx, 1.0, 0.0)
            wr = ti.select(b == gx + nx, 1.0, 0.0)
        lo, hi = self._across(d)
        ti.loop_config(serialize=True)
        for e in range(self.state.M):  # (one thread sums each member's in a fixed order)
            if self.state.live(e):
                dt_e = self.state.number(e, 1, dt)
                mass = 0.0 * dt_e
                small = 0.0 * dt_e
                for k in range(lo, hi):
                    i0, j0 = self._along(d, g - 1, k)
                    i1, j1 = self._along(d, g, k)
                    Fl = self._scaled(
                        self._face(e, i0, j0, d),
                        self.state.drain[i0, j0, e],
                        self.state.drain[i1, j1, e],
                    )
                    i0, j0 = self._along(d, g + n - 1, k)
                    i1, j1 = self._along(d, g + n, k)
                    Fr = self._scaled(
                        self._face(e, i0, j0, d),
                        self.state.drain[i0, j0, e],
                        self.state.drain[i1, j1, e],
                    )
                    mass += wl * Fl[0] - wr * Fr[0]
                    if ti.static(self.state.seg):
                        small += wl * Fl[self.state.HPHI] - wr * Fr[self.state.HPHI]
                width = (
                    self.state.par[e, Params.DY]
                    if ti.static(d == 0)
                    else self.state.par[e, Params.DX]
                )
                self.state.bud[e, 0, 2 * d] += dt_e * mass * width
                self.state.bud[e, 0, 2 * d + 1] += dt_e * small * width
