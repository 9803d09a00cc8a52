"""The finite-volume evaluation of the semi-discrete operator dq/dt = L(q, t) of (6.1)-(6.6).

A collaborator of `tiseg.solver.numerics.operator.TaichiOperator` that receives the operator's
state (`state.OperatorState`: fields, slots, ranges), its ghost cells (`ghosts.GhostCells`) and
its rest rules (`rest.RestRules`, the projected friction's face rules). Same discretisation as
the NumPy reference (`tiseg.solver.reference.operator`, whose docstring lists the steps): ghost
cells, desingularised primitives, slopes, numerical fluxes with local speeds (optionally with
the h phi flux upwinded by the mass flux), the viscous stress with harmonic face
coefficients, and the friction source. Its Taichi functions are also the pieces the slot
algebra (`slots.SlotAlgebra`: a fused stage's rate, the stage limiter) and the split sweeps
(`split.SplitSweeps`: slopes, face fluxes, viscous stresses) are built of.

The numerics components chosen by the scene are composed at construction (`compose`): the
reconstruction (`reconstruction`), the numerical flux and the h phi modifier (`fluxes`); each
returns the Taichi function the loops call, and has its NumPy twin in the reference.
"""

import taichi as ti

from ...taichi_classes import data_oriented

from ...errors import TisegError
from ...model.physics.params import Params
from .bed import BedFaces
from .fluxes import FLUXES, PHI_FLUXES
from .reconstruction import RECONSTRUCTIONS
from .state import NBUDGET
from .walls import FLUID, SOLID, WALL_HI, SolidWalls


@data_oriented
class FiniteVolume:
    def __init__(self, state, ghosts, rules):
        self.state = state
        self.ghosts = ghosts
        self.rules = rules
        cfg = state.cfg
        self.rec = RECONSTRUCTIONS[cfg.reconstruction]
        self.num_flux = FLUXES[cfg.flux]
        self.phi_flux = PHI_FLUXES[cfg.phi_flux]

    def compose(self) -> None:
        """The numerics components' Taichi functions, fixed at construction (once the fields
        exist): the kernels call them through ``ti.static`` choices, so a component not chosen
        leaves no code. ``_rec_slope``: the reconstruction's slope (None at first order);
        ``_num_flux``: the numerical flux; ``_phi_mod``: the h phi modifier (None when there is
        nothing to apply)."""
        st = self.state
        self._rec_slope = self.rec.taichi(ti, st.par, st.lay, st.fp)
        self._num_flux = self.num_flux.taichi(ti, st.phys)
        self._phi_mod = self.phi_flux.taichi(ti, st.phys, st.lay) if st.seg else None
        self._phi_modifies = self._phi_mod is not None  # (Taichi scope has no `is not`)
        # a bed: the hydrostatic reconstruction's functions (tiseg.solver.numerics.bed)
        self.has_bed = st.bed is not None
        self.bed = BedFaces(st, None if st.rec_first else self._rec_slope) if self.has_bed else None
        # solid cells: their faces are walls (tiseg.solver.numerics.walls)
        self.has_solid = st.solid is not None
        self.walls = SolidWalls(st) if self.has_solid else None
        self.terrain = self.has_bed or self.has_solid

    # ------------------------------------------------------------------ host side

    def prepare(self, slot: int, t: float) -> None:
        """Ghost cells, primitives and slopes of ``slot`` at time t, unless still current.

        A step measures its stability numbers on slot 0 and then evaluates L(slot 0) at the same
        time: the second preparation is skipped (about a third of an evaluation). A limited
        combine leaves its result's interior primitives in w, so preparing that slot next
        computes only the ghost cells' ones. Any write to the slot, a parameter change or a
        new active range makes these caches stale."""
        work = self.preparation(slot, t)
        if work[1] or work[2]:
            self._prepare(slot, work[1], work[2], self.state.serial_loops())
        self.prepared(work, t)

    def preparation(self, slot: int, t: float) -> tuple:
        """What preparing ``slot`` at time t must do, as (key, kind, mark): ``kind`` 0 nothing
        (the slot was prepared at t), 1 the ghost cells' primitives and the slopes (a limited
        combine left the interior's primitives), 2 every primitive and the slopes; ``mark``:
        take the step's rest mask (a step begins: slot 0 was written). Sets the inflow's time
        when there is work. The kernel that does it calls `prepare_in` and then hands the
        tuple to `prepared` (`prepare`; the stability pass, which prepares in its own launch)."""
        key = (slot, self.state.times(t), self.state.active)
        mark = self.state.rest is not None and self.state.rest_stale
        kind = 0
        if self.state.prepared != key:
            self.state.set_time(t)
            kind = 1 if self.state.interior == (slot, self.state.active) else 2
        return key, kind, mark

    def prepared(self, work: tuple, t: float) -> None:
        """The caches after the kernel did ``work`` (`preparation`)."""
        key, kind, mark = work
        if kind:
            self.state.prepared = key
        if mark:
            self.state.rest_stale = False
            self.state.first_stage = True
            self.state.mask_inflow = self.state.inflow_on(t)

    def no_operator(self) -> None:
        if self.state.split:
            raise TisegError(
                "numerics.stepper 'hancock' advances by sweeps (tiseg.solver.numerics.split) and "
                "has no semi-discrete operator L to evaluate"
            )

    def rhs(self, src: int, dst: int, t: float) -> None:
        """slot dst := L(slot src, t) on interior cells (fills src's ghost cells)."""
        self.no_operator()
        self.prepare(src, t)
        self.state.written(dst)
        self._rates(dst, self.state.serial_loops())

    @ti.func
    def primitive(self, e, q):
        """Desingularised primitives, u = sqrt(2) h (hu) / sqrt(h^4 + max(h^4, h_eps^4)).
        (The split scheme's cheaper form of the same, FiniteVolume.fast_primitive, in a split
        scene: every primitive of a run then comes from one formula.)"""
        if ti.static(self.state.split):
            return self.fast_primitive(e, q)
        h = ti.max(q[0], 0.0)
        h4 = h * h * h * h
        denom = ti.sqrt(h4 + ti.max(h4, self.state.par[e, Params.H_EPS4]))
        return self.primitive_of(q, h, ti.sqrt(2.0) * h / denom)

    @ti.func
    def primitive_of(self, q, h, r):
        """w of q with h = max(q_h, 0) and the velocities r times the momenta."""
        w = q
        w[0] = h
        for c in ti.static(range(1, self.state.nc)):
            w[c] = r * q[c]
        if ti.static(self.state.seg):
            # phi is bounded (0 <= h phi <= h after every stage), so it needs no
            # desingularisation, which would pull it towards 0 in thin films
            phi = 0.0 * h
            if h > 0:
                phi = ti.min(ti.max(q[self.state.HPHI] / h, 0.0), 1.0)
            w[self.state.HPHI] = phi
        return w

    @ti.func
    def slope(self, e, wm, w0, wp):
        """Undivided limited slope of w0 from its neighbours; edge values w0 +- slope/2: the
        reconstruction's slope, limited so that the edges keep h >= 0 and 0 <= phi <= 1."""
        dm = w0 - wm
        dp = wp - w0
        dc = 0.5 * (wp - wm)
        # the reconstruction's slope (tiseg.solver.numerics.reconstruction)
        s = self._rec_slope(e, dm, dp, dc)
        # positivity of h and 0 <= phi <= 1 at the edges
        s[0] = ti.min(ti.max(s[0], -2.0 * w0[0]), 2.0 * w0[0])
        if ti.static(self.state.seg):
            p = w0[self.state.HPHI]
            lim = 2.0 * ti.min(p, 1.0 - p)
            s[self.state.HPHI] = ti.min(ti.max(s[self.state.HPHI], -lim), lim)
        return s

    @ti.kernel
    def _prepare(self, s: ti.i32, kind: ti.template(), rest: ti.template(), serial: ti.template()):
        """Everything an evaluation needs from slot s before the fluxes, in one launch (each
        launch costs tens of microseconds of Python and thread start-up: on small grids
        that, not arithmetic, sets the pace): `prepare_in` (the rest mask alone where the
        slot was prepared already)."""
        self.prepare_in(s, kind, rest, serial)

    @ti.func
    def prepare_in(self, s, kind: ti.template(), rest: ti.template(), serial: ti.template()):
        """The preparation of slot s in the calling kernel (`preparation` says what): ghost
        cells, their primitives (``kind`` 1: a limited combine left the interior's in w) or
        every primitive (``kind`` 2), the slopes; with ``rest`` then the step's rest mask of
        these primitives (`RestRules.mark`). Top-level loops run in order."""
        if ti.static(kind > 0):
            self.ghosts.fill(s)
            if ti.static(kind == 1):
                self.edge_primitives(s, serial)
            else:
                self.primitives(s, serial)
            self._slopes(serial)
        if ti.static(rest):
            self.rules.mark(serial)

    @ti.func
    def primitives(self, s, serial: ti.template()):
        a, b = self.state.act[0], self.state.act[1]
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange(
            (ti.max(a - 3, 0), ti.min(b + 3, self.state.NX)), (0, self.state.NY), self.state.M
        ):
            self.state.w[i, j, e] = self.primitive(e, self.state.q[s, i, j, e])

    @ti.func
    def edge_primitives(self, s, serial: ti.template()):
        """Primitives of the ghost cells among those primitives covers (the x range
        [a - 3, b + 3), every row); the interior ones are those _combine_cells wrote."""
        gx, nx, gy, ny = ti.static(self.state.gx, self.state.nx, self.state.gy, self.state.ny)
        a, b = self.state.act[0], self.state.act[1]
        ti.loop_config(serialize=self.state.strip_serial)  # 2 x 2 columns
        for k, j, e in ti.ndrange(gx, self.state.NY, self.state.M):
            il = gx - 1 - k
            ih = gx + nx + k
            if il >= a - 3:
                self.state.w[il, j, e] = self.primitive(e, self.state.q[s, il, j, e])
            if ih < b + 3:
                self.state.w[ih, j, e] = self.primitive(e, self.state.q[s, ih, j, e])
        if ti.static(not self.state.is_1d):
            ti.loop_config(serialize=serial)
            for i, k, e in ti.ndrange(
                (ti.max(a - 3, gx), ti.min(b + 3, gx + nx)), gy, self.state.M
            ):
                jl = gy - 1 - k
                jh = gy + ny + k
                self.state.w[i, jl, e] = self.primitive(e, self.state.q[s, i, jl, e])
                self.state.w[i, jh, e] = self.primitive(e, self.state.q[s, i, jh, e])

    @ti.func
    def _slopes(self, serial: ti.template()):
        a, b = self.state.act[0], self.state.act[1]
        if ti.static(not self.state.rec_first and not self.state.split):
            # x slopes on the interior rows of [a - 2, b + 2), y slopes on [a, b) and the
            # ghost rows next to the interior: one pass over w for both (memory, not
            # arithmetic, sets the pace of these loops on large grids)
            gy, ny = ti.static(self.state.gy, self.state.ny)
            jlo, jhi = ti.static((1, self.state.NY - 1) if not self.state.is_1d else (0, 1))
            ti.loop_config(serialize=serial)
            for i, j, e in ti.ndrange(
                (ti.max(a - 2, 1), ti.min(b + 2, self.state.NX - 1)), (jlo, jhi), self.state.M
            ):
                w0 = self.state.w[i, j, e]
                if gy <= j < gy + ny:
                    self.state.sx[i, j, e] = self.slope(
                        e, self.state.w[i - 1, j, e], w0, self.state.w[i + 1, j, e]
                    )
                    if ti.static(self.has_bed):  # and of eta (tiseg.solver.numerics.bed)
                        self.bed.keep_slopes(e, i, j, True, False)
                if ti.static(not self.state.is_1d):
                    if a <= i < b:
                        self.state.sy[i, j, e] = self.slope(
                            e, self.state.w[i, j - 1, e], w0, self.state.w[i, j + 1, e]
                        )
                        if ti.static(self.has_bed):
                            self.bed.keep_slopes(e, i, j, False, True)

    @ti.func
    def face_flux(self, e, wl, wr, d: ti.template(), g):
        """Numerical flux between edge states wl | wr along d: the chosen numerical flux
        (numerics.flux), then, with segregation, the h phi modifier (numerics.phi_flux); both
        components of tiseg.solver.numerics.fluxes. g: the face's gravity
        (tiseg.solver.numerics.gravity)."""
        F = self._num_flux(e, wl, wr, d, g)
        if ti.static(self._phi_modifies):
            F = self._phi_mod(e, F, wl, wr)
        return F

    @ti.kernel
    def _rates(self, d: ti.i32, serial: ti.template()):
        """slot d := L from the prepared primitives and slopes: face fluxes, their divergence
        plus sources, and the boundary budget rates, in one launch."""
        self.face_fluxes(serial)
        self._divergence(d, serial)
        self.boundary_rates(d)

    @ti.func
    def face_wet(self, e, w0, w1, hmin, i0, j0, i1, j1):
        """Whether the face between cells (i0, j0) and (i1, j1), primitives w0 and w1, carries
        a convective flux: one of the cells is at least h_min thick; with the projected
        friction also where one of them was at the step's start (RestRules.wet_at_start).
        In the split sweeps also where one is a film (thinner) that moves, or with the
        projected friction moved at the step's start (RestRules.live_at_start). So no mass
        moves between two films at rest (a dry bed stays dry), while a film that flows
        carries its mass on: a front thins as the exact one does instead of waiting at h_min
        in each cell it enters (Physics.acts)."""
        wet = ti.max(w0[0], w1[0]) >= hmin
        if not wet:
            if ti.static(self.state.phys.fr_projected and self.state.phys.films):
                wet = self.rules.live_at_start(e, i0, j0, i1, j1)
            elif ti.static(self.state.phys.fr_projected):
                wet = self.rules.wet_at_start(e, i0, j0, i1, j1)
            elif ti.static(self.state.phys.films):
                wet = self.rules.moving(w0) or self.rules.moving(w1)
        return wet

    @ti.func
    def _x_face(self, e, i, j):
        """Flux through the face between cells (i, j) and (i + 1, j): convective plus viscous."""
        hmin = self.state.par[e, Params.H_MIN]
        w0 = self.state.w[i, j, e]
        w1 = self.state.w[i + 1, j, e]
        F = ti.Vector.zero(self.state.fp, self.state.nc)
        if ti.static(self.terrain):
            F = self._terrain_face(e, i, j, i + 1, j, w0, w1, hmin, 0)
        elif self.face_wet(e, w0, w1, hmin, i, j, i + 1, j):
            wl = w0
            wr = w1
            if ti.static(not self.state.rec_first):
                wl = w0 + 0.5 * self.state.sx[i, j, e]
                wr = w1 - 0.5 * self.state.sx[i + 1, j, e]
            F = self.face_flux(e, wl, wr, 0, self.state.grav.xface(e, i))
            F = self.rules.rest_face(e, F, wl, wr, 0, i, j, i + 1, j)
        if ti.static(self.state.visc):  # the viscous stress (tiseg.model.physics.viscosity)
            F = self.x_viscous(e, F, i, j, w0, w1)
        return F

    @ti.func
    def _edge_states(self, e, i0, j0, i1, j1, w0, w1, d: ti.template()):
        """The reconstructed edge states facing each other across the face (i0, j0) |
        (i1, j1) along d: the high edge of the first cell, the low edge of the second."""
        wl = w0
        wr = w1
        if ti.static(not self.state.rec_first):
            if ti.static(d == 0):
                wl = w0 + 0.5 * self.state.sx[i0, j0, e]
                wr = w1 - 0.5 * self.state.sx[i1, j1, e]
            else:
                wl = w0 + 0.5 * self.state.sy[i0, j0, e]
                wr = w1 - 0.5 * self.state.sy[i1, j1, e]
        return wl, wr

    @ti.func
    def _terrain_face(self, e, i0, j0, i1, j1, w0, w1, hmin, d: ti.template()):
        """The convective flux of a face over a bed or next to solid cells: a wall's fluid side
        and its mirror (tiseg.solver.numerics.walls); over a bed the numerical flux of the
        edge states with h* and each side's pressure correction into pcx / pcy (the whole
        pressure of each edge where the face carries no convective flux, none at a wall:
        tiseg.solver.numerics.bed)."""
        wl, wr = self._edge_states(e, i0, j0, i1, j1, w0, w1, d)
        kind = FLUID
        if ti.static(self.has_solid):
            kind = self.walls.kind(i0, j0, i1, j1)
            wl, wr = self.walls.faced(kind, wl, wr, d)
        F = ti.Vector.zero(self.state.fp, self.state.nc)
        wet = self.face_wet(e, w0, w1, hmin, i0, j0, i1, j1) and kind != SOLID
        g = self.state.grav.face(e, i0, d)
        if ti.static(self.has_bed):
            bl = self.bed.edge_hi(e, i0, j0, d, wl[0])
            br = self.bed.edge_lo(e, i1, j1, d, wr[0])
            if kind == WALL_HI:
                br = bl
            elif kind != FLUID:
                bl = br
            p = self.bed.dry(wl[0], wr[0], g)
            if kind == SOLID:
                p = p * 0.0
            if wet:
                wl, wr, p = self.bed.star(wl, bl, wr, br, g)
            if ti.static(d == 0):
                self.state.pcx[i0, j0, e] = p
            else:
                self.state.pcy[i0, j0, e] = p
        if wet:
            F = self.face_flux(e, wl, wr, d, g)
            if kind == FLUID:  # (at a wall, the mirror's flux: nothing crosses)
                F = self.rules.rest_face(e, F, wl, wr, d, i0, j0, i1, j1)
        return F

    @ti.func
    def sweep_terrain(self, e, i0, j0, i1, j1, d: ti.template(), wl, wr, wet):
        """A split sweep's face over a bed or next to solid cells, between the predicted
        edges wl | wr: (wl, wr, wet, fluid) as the face takes them (a wall's fluid side and
        its mirror, h* over a bed with the pressure corrections stored; `_terrain_face`)."""
        kind = FLUID
        if ti.static(self.has_solid):
            kind = self.walls.kind(i0, j0, i1, j1)
            wl, wr = self.walls.faced(kind, wl, wr, d)
            wet = wet and kind != SOLID
        if ti.static(self.has_bed):
            g = self.state.grav.face(e, i0, d)
            wl, wr = self.bed.sweep_face(e, i0, j0, i1, j1, d, wl, wr, wet, kind, g)
        return wl, wr, wet, kind == FLUID

    @ti.func
    def bed_rate(self, e, i, j, d: ti.template()):
        """The normal momentum rate of cell (i, j) from the bed along d: the faces' pressure
        corrections and the centred source (tiseg.solver.numerics.bed), per unit area."""
        h0 = self.state.w[i, j, e][0]
        h_lo = h0
        h_hi = h0
        if ti.static(not self.state.rec_first):
            s = h0 * 0.0
            if ti.static(d == 0):
                s = self.state.sx[i, j, e][0]
            else:
                s = self.state.sy[i, j, e][0]
            h_lo = h0 - 0.5 * s
            h_hi = h0 + 0.5 * s
        b_lo, b_hi = self.bed.edges(e, i, j, d, h_lo, h_hi)
        r = self.bed.centred(h_lo, h_hi, b_lo, b_hi, self.state.grav.cell(e, i))
        inv = self.state.par[e, Params.INV_DX]
        if ti.static(d == 0):
            r -= self.state.pcx[i, j, e][0] - self.state.pcx[i - 1, j, e][1]
        else:
            r -= self.state.pcy[i, j, e][0] - self.state.pcy[i, j - 1, e][1]
            inv = self.state.par[e, Params.INV_DY]
        return r * inv

    @ti.func
    def x_viscous(self, e, F, i, j, w0, w1):
        """F minus the viscous stress of (6.2) through the x face (i, j) | (i + 1, j), whose
        cells' primitives are w0, w1 (the cross derivative from the rows j -+ 1 of w)."""
        ph = self.state.phys
        idx = self.state.par[e, Params.INV_DX]
        K = ph.face_K(e, w0[0], w1[0])
        F[1] -= ph.normal_stress(e, K, w1[1] - w0[1], idx)
        if ti.static(not self.state.is_1d):
            HV = ti.static(self.state.HV)
            idy = self.state.par[e, Params.INV_DY]
            # paired differences: exactly zero for y-independent data
            dudy = (
                (self.state.w[i, j + 1, e][1] - self.state.w[i, j - 1, e][1])
                + (self.state.w[i + 1, j + 1, e][1] - self.state.w[i + 1, j - 1, e][1])
            ) * (0.25 * idy)
            F[HV] -= ph.shear_stress(e, K, w1[HV] - w0[HV], idx, dudy)
        return F

    @ti.func
    def _y_face(self, e, i, j):
        """Flux through the face between cells (i, j) and (i, j + 1) (2D only)."""
        hmin = self.state.par[e, Params.H_MIN]
        w0 = self.state.w[i, j, e]
        w1 = self.state.w[i, j + 1, e]
        F = ti.Vector.zero(self.state.fp, self.state.nc)
        if ti.static(self.terrain):
            F = self._terrain_face(e, i, j, i, j + 1, w0, w1, hmin, 1)
        elif self.face_wet(e, w0, w1, hmin, i, j, i, j + 1):
            wl = w0
            wr = w1
            if ti.static(not self.state.rec_first):
                wl = w0 + 0.5 * self.state.sy[i, j, e]
                wr = w1 - 0.5 * self.state.sy[i, j + 1, e]
            F = self.face_flux(e, wl, wr, 1, self.state.grav.cell(e, i))
            F = self.rules.rest_face(e, F, wl, wr, 1, i, j, i, j + 1)
        if ti.static(self.state.visc):
            F = self.y_viscous(e, F, i, j, w0, w1)
        return F

    @ti.func
    def y_viscous(self, e, F, i, j, w0, w1):
        """F minus the viscous stress of (6.2) through the y face (i, j) | (i, j + 1) (2D)."""
        HV = ti.static(self.state.HV)
        ph = self.state.phys
        idx = self.state.par[e, Params.INV_DX]
        idy = self.state.par[e, Params.INV_DY]
        K = ph.face_K(e, w0[0], w1[0])
        F[HV] -= ph.normal_stress(e, K, w1[HV] - w0[HV], idy)
        dvdx = (
            (self.state.w[i + 1, j, e][HV] - self.state.w[i - 1, j, e][HV])
            + (self.state.w[i + 1, j + 1, e][HV] - self.state.w[i - 1, j + 1, e][HV])
        ) * (0.25 * idx)
        F[1] -= ph.shear_stress(e, K, w1[1] - w0[1], idy, dvdx)
        return F

    @ti.func
    def face_fluxes(self, serial: ti.template()):
        """x faces (i, i + 1) for i in [a - 1, b) on the interior rows; y faces (j, j + 1) for
        j in [gy - 1, gy + ny) on the columns [a, b). In 2D one pass does both, so each cell's
        primitives and slopes are read once per evaluation."""
        gy, ny = ti.static(self.state.gy, self.state.ny)
        a, b = self.state.act[0], self.state.act[1]
        if ti.static(self.state.is_1d):
            ti.loop_config(serialize=serial)
            for i, j, e in ti.ndrange((a - 1, b), (gy, gy + ny), self.state.M):
                self.state.fx[i, j, e] = self._x_face(e, i, j)
        else:
            ti.loop_config(serialize=serial)
            for i, j, e in ti.ndrange((a - 1, b), (gy - 1, gy + ny), self.state.M):
                if j >= gy:
                    self.state.fx[i, j, e] = self._x_face(e, i, j)
                if i >= a:
                    self.state.fy[i, j, e] = self._y_face(e, i, j)

    @ti.func
    def cell_rate(self, e, i, j):
        """L at cell (i, j) from the face fluxes and the source: (6.1)-(6.6) in flux form,
        plus the scene's source terms (`source_terms.SourceTerms`); zero outside the active x
        range."""
        idx = self.state.par[e, Params.INV_DX]
        idy = self.state.par[e, Params.INV_DY]
        a, b = self.state.act[0], self.state.act[1]
        r = ti.Vector.zero(self.state.fp, self.state.nc)
        if a <= i < b:
            r = -(self.state.fx[i, j, e] - self.state.fx[i - 1, j, e]) * idx
            if ti.static(not self.state.is_1d):
                r -= (self.state.fy[i, j, e] - self.state.fy[i, j - 1, e]) * idy
            r += self.state.phys.source(e, self.state.w[i, j, e], self.state.grav.cell(e, i))
            if ti.static(self.state.terms.on):  # the scene's terms beyond (6.4)
                r += self.state.terms.rate(e, i, j)
            if ti.static(self.has_bed):  # the bed's pressure (tiseg.solver.numerics.bed)
                r[1] += self.bed_rate(e, i, j, 0)
                if ti.static(not self.state.is_1d):
                    r[self.state.HV] += self.bed_rate(e, i, j, 1)
            if ti.static(self.has_solid):  # a solid cell never changes
                if self.walls.is_solid(i, j):
                    r = ti.Vector.zero(self.state.fp, self.state.nc)
        return r

    @ti.func
    def _divergence(self, d, serial: ti.template()):
        gx, nx, gy, ny = ti.static(self.state.gx, self.state.nx, self.state.gy, self.state.ny)
        a, b = self.state.act[0], self.state.act[1]
        # rates on the active range and zero on the 3 cells either side that a combination also
        # reads; further out nothing reads them while this range holds (SlotAlgebra._combine)
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange(
            (ti.max(a - 3, gx), ti.min(b + 3, gx + nx)), (gy, gy + ny), self.state.M
        ):
            self.state.q[d, i, j, e] = self.cell_rate(e, i, j)

    @ti.func
    def fast_primitive(self, e, q):
        """FiniteVolume.primitive, with its square root only where it matters: for
        h >= h_eps the desingularised velocity sqrt(2) h (hu) / sqrt(h^4 + max(h^4, h_eps^4))
        is (hu) / h, up to rounding."""
        h = ti.max(q[0], 0.0)
        h4 = h * h * h * h
        r = 0.0 * h
        if h4 >= self.state.par[e, Params.H_EPS4]:
            r = 1.0 / h
        else:
            r = ti.sqrt(2.0) * h / ti.sqrt(h4 + self.state.par[e, Params.H_EPS4])
        return self.primitive_of(q, h, r)

    @ti.func
    def limit(self, e, v):
        """The stage limiter: h >= 0, no momentum in films thinner than h_min (where there
        is no material in the split sweeps, whose films flow: Physics.acts), 0 <= h phi <= h."""
        h = ti.select(v[0] < 0.0, 0.0, v[0])  # unlike max(), lets a NaN through to the guard
        v[0] = h
        if not self.state.phys.acts(e, h):
            v[1] = 0.0
            if ti.static(not self.state.is_1d):
                v[self.state.HV] = 0.0
        if ti.static(self.state.seg):
            v[self.state.HPHI] = ti.min(ti.max(v[self.state.HPHI], 0.0), h)
        return v

    @ti.func
    def boundary_rates(self, d):
        """Net inflow rates through the domain's faces, summed in a fixed order (each
        member's)."""
        gx, nx, gy, ny = ti.static(self.state.gx, self.state.nx, self.state.gy, self.state.ny)
        M = ti.static(self.state.M)
        ti.loop_config(serialize=True)
        for b, e in ti.ndrange(NBUDGET, M):
            self.state.bud[e, d, b] = 0.0
        # faces outside the active range were not computed this time: they carry no flux
        wl = 1.0 if self.state.act[0] == gx else 0.0
        wr = 1.0 if self.state.act[1] == gx + nx else 0.0
        ti.loop_config(serialize=True)
        for j, e in ti.ndrange((gy, gy + ny), M):
            dy = self.state.par[e, Params.DY]
            self.state.bud[e, d, 0] += (
                wl * self.state.fx[gx - 1, j, e][0] - wr * self.state.fx[gx + nx - 1, j, e][0]
            ) * dy
            if ti.static(self.state.seg):
                self.state.bud[e, d, 1] += (
                    wl * self.state.fx[gx - 1, j, e][self.state.HPHI]
                    - wr * self.state.fx[gx + nx - 1, j, e][self.state.HPHI]
                ) * dy
        if ti.static(not self.state.is_1d):
            ti.loop_config(serialize=True)
            for i, e in ti.ndrange((self.state.act[0], self.state.act[1]), M):
                dx = self.state.par[e, Params.DX]
                self.state.bud[e, d, 2] += (
                    self.state.fy[i, gy - 1, e][0] - self.state.fy[i, gy + ny - 1, e][0]
                ) * dx
                if ti.static(self.state.seg):
                    self.state.bud[e, d, 3] += (
                        self.state.fy[i, gy - 1, e][self.state.HPHI]
                        - self.state.fy[i, gy + ny - 1, e][self.state.HPHI]
                    ) * dx
