"""The semi-discrete operator dq/dt = L(q, t) of (6.1)-(6.6) in Taichi kernels.

Same discretisation as the NumPy reference (`tiseg.solver.reference.operator`, whose docstring
lists the steps): ghost cells, desingularised primitives, slopes, numerical fluxes with local
speeds (optionally with the h phi flux upwinded by the mass flux), the viscous stress with
harmonic face coefficients, and the friction source.

The operator is composed, in the shape of the physics laws (`tiseg.model.physics`), of numerics
components chosen by the scene and fixed at construction (`TaichiOperator._compose`): the
reconstruction (`reconstruction`), the numerical flux and the h phi modifier
(`fluxes`), a boundary condition per side (`boundaries`); each returns the Taichi
function its loops call, and has its NumPy twin in the reference. Around them:

* `ranges.ActiveRange` (collaborator): the active x range and serial or parallel loops;
* `reductions.StepReductions` (collaborator): the stability pass and the totals;
* `slots.SlotAlgebra`: combinations of slots, fused stages, the stage limiter, budgets;
* `rest.RestRules`: the projected friction's rest mask, face rules and projection;
* `split.SplitSweeps`: the sweeps of the split scheme.

The last three are parts of this class (they work on its fields and caches). States live in one
field ``q`` of ``nslots`` slots (Taichi compiles one kernel per distinct field passed as template,
so buffers are slots selected by an integer). Time steppers (`tiseg.solver.timestepping`) see only
`rhs`, `combine` / `stage` (with the stage limiter) and `stability`.
"""

import numpy as np
import taichi as ti

from ... import backend
from ..field_tree import FieldTree
from ...model.physics.pointwise import Params, Physics, param_count, param_values
from .boundaries import BOUNDARIES
from .config import OperatorConfig
from .fluxes import FLUXES, PHI_FLUXES
from .reconstruction import RECONSTRUCTIONS
from .ranges import SERIAL_CELLS, ActiveRange, row_pieces  # noqa: F401 (public name)
from .reductions import NSTAB, StabilityNumbers, StepReductions  # noqa: F401 (public names)
from .rest import HELD, REST, WET, X_NEG, X_POS, Y_NEG, Y_POS, RestRules  # noqa: F401
from .slots import MAX_TERMS, NBUDGET, SlotAlgebra  # noqa: F401 (public names)
from .split import SplitSweeps
from ...errors import TisegError


@ti.data_oriented
class TaichiOperator(SlotAlgebra, RestRules, SplitSweeps):
    def __init__(self, cfg: OperatorConfig, nslots: int = 6, serial: bool | None = None):
        """``serial``: run every loop on the calling thread (True), never (False), or decide
        per launch (None, `serial_loops`); the results are the same bits either way."""
        st = backend.state()
        self.generation = st.generation
        self.cfg = cfg
        lay = cfg.layout
        self.lay = lay
        self.nslots = nslots
        self.fp = ti.f64 if st.precision == "f64" else ti.f32
        self.np_fp = np.float64 if st.precision == "f64" else np.float32
        nc, NX, NY = lay.nc, lay.NX, lay.NY
        # compile-time constants
        self.nc, self.NX, self.NY = nc, NX, NY
        self.nx, self.ny, self.gx, self.gy = lay.nx, lay.ny, lay.gx, lay.gy
        self.is_1d, self.seg, self.visc = lay.is_1d, lay.segregation, cfg.viscous
        self.H, self.HU, self.HV, self.HPHI = lay.H, lay.HU, lay.HV, lay.HPHI
        # the numerics components (tiseg.solver.numerics.reconstruction, .fluxes, .boundaries): their
        # Taichi functions are built once the fields exist (_compose)
        self.rec = RECONSTRUCTIONS[cfg.reconstruction]
        self.rec_first = not self.rec.slopes
        self.num_flux = FLUXES[cfg.flux]
        self.phi_flux = PHI_FLUXES[cfg.phi_flux]
        self.local_rate = bool(cfg.local_step_rate) and not self.is_1d
        # the split scheme (numerics.stepper "hancock", tiseg.solver.numerics.split): sweeps instead
        # of evaluations of L, with their own edge fields and no stored slopes
        self.split = bool(cfg.split)
        self.bc = tuple(cfg.bc)
        self.bcs = tuple(BOUNDARIES[b] for b in cfg.bc)  # x_lo, x_hi, y_lo, y_hi
        # fields: only what this scene needs (no y slopes/fluxes in 1D, nc follows the effects),
        # in one field tree that is freed with the operator
        ft = self.field_tree = FieldTree()
        self.q = ft.vector(nc, self.fp, (nslots, NX, NY))
        self.w = ft.vector(nc, self.fp, (NX, NY))
        self.fx = ft.vector(nc, self.fp, (NX, NY))
        slopes = not self.rec_first and not self.split
        self.sx = ft.vector(nc, self.fp, (NX, NY)) if slopes else None
        if not self.is_1d:
            self.fy = ft.vector(nc, self.fp, (NX, NY))
            self.sy = ft.vector(nc, self.fp, (NX, NY)) if slopes else None
        if self.split:  # a sweep's predicted edge states and draining factors
            self.ew = ft.vector(nc, self.fp, (NX, NY))
            self.ee = ft.vector(nc, self.fp, (NX, NY))
            self.drain = ft.field(self.fp, (NX, NY))
        self.par = ft.field(self.fp, param_count(cfg))
        # inflow concentration per cross-slope cell: only with an inflow that carries phi
        self.inflow_prof = ft.field(self.fp, NY) if self.seg and cfg.bc[0] == "inflow" else None
        # Active range [a, b) of x indices whose cells may change, the wet scan's range and the
        # serial-or-parallel choice (tiseg.solver.numerics.ranges); its fields, which the kernels
        # read, under their old names. Serial loops: forced (True/False), or chosen from the
        # cells a launch covers, for the active range when the range is set (set_active).
        threads = st.threads or backend.available_cores()
        self.ranges = ActiveRange(ft, lay, serial, threads, st.arch == "cpu")
        # loops over a strip of cells (ghost columns and rows: a few thousand cells) run on one
        # CPU thread, where a hand-off costs more than the work; on a GPU one thread would
        # walk the strip alone (1 ms a launch at 750 cells/m on an H200, most of a step), so
        # there they run in parallel. Each iteration writes its own cells: the same bits.
        self.strip_serial = st.arch == "cpu"
        self.act, self.wet, self.wrng = self.ranges.act, self.ranges.wet, self.ranges.wrng
        # rows reduced by one thread before one atomic (_stability, _wet_extent): a row in 2D,
        # 256 cells in 1D (one row of NX cells), where per-cell atomics would contend
        self.rows_per_block = max(1, 256 // NY)
        # ... and each row cut into this many pieces along y, reduced one by one: Taichi's
        # CPU backend hands a parallel loop to its threads in equal chunks of at least 512
        # iterations, so a loop over the ~500 rows of a fingers run's active range ran on
        # one thread; the pieces give the smallest range that runs in parallel
        # (SERIAL_CELLS cells) 512 iterations per thread. On a GPU, many threads.
        self.row_pieces = row_pieces(lay, threads, st.arch == "cpu")
        self._prepared = None  # (slot, t, active range) whose primitives are in w
        # (slot, active range) whose interior primitives a limited combine left in w (ghost
        # cells and slopes still to do)
        self._interior = None
        # Boundary budgets per slot: rates of (mass, small-particle mass) entering through the
        # x faces and the y faces. combine() applies the same linear combination to them as to
        # the states, so slot 0 accumulates exactly the time integral the scheme uses.
        # (row nslots: the boundary rates of a fused stage, whose rate has no slot)
        self.bud = ft.field(self.fp, (nslots + 1, NBUDGET))
        self.phys = Physics(cfg, self.par)
        # With the projected friction: which cells were at rest at the start of the step, the
        # state in slot 0 (_rest_face). Recomputed at the first preparation after slot 0 is
        # written, so every stage of a step sees the same rest faces.
        self.rest = ft.field(ti.i8, (NX, NY)) if self.phys.fr_projected else None
        # the split step's friction acts once, after its last sweep, at the speed of the step's
        # initial state (SplitSweeps.sweep): in 2D that speed is kept from the first sweep
        # (in 1D as well when a viscous sub-step may open the step)
        spd = self.split and self.phys.fr_projected and (not self.is_1d or self.visc)
        self.spd0 = ft.field(self.fp, (NX, NY)) if spd else None
        # and the thickness the x sweep's gravity acted on, for the friction of a 2D step
        # whose last sweep is along y (SplitSweeps._sweep_update)
        hg = self.split and self.phys.fr_projected and not self.is_1d
        self.hg = ft.field(self.fp, (NX, NY)) if hg else None
        self._rest_stale = True
        # A law with hysteresis holds resting cells exactly for a whole step (HELD): columns
        # of such cells far from any moving one then need no work at all, and the active range
        # leaves them out (_quiescent, Simulation._set_active). Decided from the rest mask of
        # the step before, so the mask is part of the run's state (checkpoints keep it).
        self.skip_rest = bool(self.phys.fr_projected and self.phys.law.hysteresis)
        self._first_stage = False  # the next limited combination is a step's first stage
        # the stability pass and the conservation totals (tiseg.solver.numerics.reductions)
        self.reduce = StepReductions(self, ft)
        ft.finalize()  # the fields exist from here on
        ft.free_with(self)
        self._compose()
        self.set_active(self.gx, self.gx + self.nx)
        self.set_params(cfg)
        self.t = 0.0

    def _compose(self) -> None:
        """The numerics components' Taichi functions for this operator, fixed at construction:
        the kernels call them through ``ti.static`` choices, so a component not chosen leaves
        no code. ``_fill``: the ghost fillers of (x_lo, x_hi[, y_lo, y_hi]); ``_rec_slope``:
        the reconstruction's slope (None at first order); ``_num_flux``: the numerical flux;
        ``_phi_mod``: the h phi modifier (None when there is nothing to apply)."""
        dims = (0,) if self.is_1d else (0, 1)
        self._fill = tuple(
            self.bcs[2 * d + side].taichi(ti, self, d, side) for d in dims for side in (0, 1)
        )
        self._rec_slope = self.rec.taichi(ti, self.par, self.lay, self.fp)
        self._num_flux = self.num_flux.taichi(ti, self.phys)
        self._phi_mod = self.phi_flux.taichi(ti, self.phys, self.lay) if self.seg else None
        self._phi_modifies = self._phi_mod is not None  # (Taichi scope has no `is not`)

    # ------------------------------------------------------------------ parameters
    def set_params(self, cfg: OperatorConfig) -> None:
        """Copy run-time numbers into the parameter field (no recompilation)."""
        P = Params
        p = np.zeros(param_count(cfg))
        p[P.G_COS], p[P.G_SIN] = cfg.g_cos, cfg.g_sin
        p[P.H_MIN], p[P.H_EPS4], p[P.U_EPS] = cfg.h_min, cfg.h_eps**4, cfg.u_eps
        p[P.THETA], p[P.WENO_EPS] = cfg.theta, cfg.weno_eps
        p[P.PHI_REF], p[P.DX], p[P.DY] = cfg.phi_ref, cfg.dx, cfg.dy
        comp = param_values(cfg)  # the components' numbers, from COUNT on
        p[P.COUNT : P.COUNT + len(comp)] = comp
        p[P.IN_U] = cfg.inflow_u
        p[P.INV_DX], p[P.INV_DY] = 1.0 / cfg.dx, 1.0 / cfg.dy
        p[P.INV_H_REF], p[P.INV_U_REF] = 1.0 / cfg.h_ref, 1.0 / cfg.u_ref
        self.cfg = cfg
        self._prepared = self._interior = None
        self._rest_stale = True
        # a new h_min may make films outside the active range wet (the range is set before
        # the first call, in __init__), and new numbers may start resting cells
        self.set_active(self.gx, self.gx + self.nx)
        self._forget_rest()
        self.par.from_numpy(p.astype(self.np_fp))
        if self.inflow_prof is not None:
            # the inflow concentration profile (6.9) + noise, computed once on the host: no
            # 64-bit transcendental functions in the kernels (SPIR-V has none), and the same
            # numbers as the NumPy reference
            prof = np.zeros(self.NY)
            y = (np.arange(self.ny) + 0.5) * cfg.dy
            prof[self.gy : self.gy + self.ny] = cfg.inflow_phi_profile(y)
            self.inflow_prof.from_numpy(prof.astype(self.np_fp))
        self._inflow_key = None

    def _set_time(self, t: float) -> None:
        """Inflow thickness of (6.8) at the stage time t (ramp) and whether it still flows."""
        if self.bc[0] != "inflow":
            return
        h, _, _ = self.cfg.inflow_state(t)
        on = 1.0 if self.inflow_on(t) else 0.0
        key = (h, on)
        if key != self._inflow_key:
            self.par[Params.IN_H] = h
            self.par[Params.IN_ON] = on
            self._inflow_key = key

    # ------------------------------------------------------------------ host access
    def check_alive(self) -> None:
        if backend.state().generation != self.generation:
            raise TisegError(
                "Taichi was re-initialised (tiseg.init with other settings); "
                "this simulation's fields no longer exist: create it again"
            )

    def get(self, slot: int = 0) -> np.ndarray:
        """Slot as a float64 array shaped (nc, NX, NY)."""
        a = self.q.to_numpy()[slot]
        return np.moveaxis(a, -1, 0).astype(np.float64)

    def set(self, slot: int, arr: np.ndarray) -> None:
        self._prepared = self._interior = None
        self._rest_stale = self._rest_stale or slot == 0
        self.set_active(self.gx, self.gx + self.nx)  # wet cells may now lie anywhere
        if slot == 0:
            self._forget_rest()  # and any of them may move
        full = self.q.to_numpy()
        full[slot] = np.moveaxis(np.asarray(arr), 0, -1).astype(self.np_fp)
        self.q.from_numpy(full)

    # ------------------------------------------------------------------ kernels
    @ti.func
    def _ghosts(self, s):
        """Ghost cells of slot s from the boundary conditions (two top-level loops): each
        side's component (tiseg.solver.numerics.boundaries) fills its cells, low side first."""
        gx, gy = ti.static(self.gx, self.gy)
        ti.loop_config(serialize=self.strip_serial)  # 2 columns of cells
        for k, j in ti.ndrange(gx, (0, self.NY)):
            self._fill[0](s, k, j)
            self._fill[1](s, k, j)
        if ti.static(not self.is_1d):
            ti.loop_config(serialize=self.strip_serial)  # 2 rows of cells
            for i, k in ti.ndrange((0, self.NX), gy):
                self._fill[2](s, k, i)
                self._fill[3](s, k, i)

    @ti.func
    def _primitive(self, q):
        """Desingularised primitives, u = sqrt(2) h (hu) / sqrt(h^4 + max(h^4, h_eps^4)).
        (The split scheme's cheaper form of the same, SplitSweeps._fast_primitive, in a split
        scene: every primitive of a run then comes from one formula.)"""
        if ti.static(self.split):
            return self._fast_primitive(q)
        h = ti.max(q[0], 0.0)
        h4 = h * h * h * h
        denom = ti.sqrt(h4 + ti.max(h4, self.par[Params.H_EPS4]))
        return self._primitive_of(q, h, ti.sqrt(2.0) * h / denom)

    @ti.func
    def _primitive_of(self, q, h, r):
        """w of q with h = max(q_h, 0) and the velocities r times the momenta."""
        w = q
        w[0] = h
        for c in ti.static(range(1, self.nc)):
            w[c] = r * q[c]
        if ti.static(self.seg):
            # phi is bounded (0 <= h phi <= h after every stage), so it needs no
            # desingularisation, which would pull it towards 0 in thin films
            phi = 0.0 * h
            if h > 0:
                phi = ti.min(ti.max(q[self.HPHI] / h, 0.0), 1.0)
            w[self.HPHI] = phi
        return w

    @ti.func
    def _slope(self, wm, w0, wp):
        """Undivided limited slope of w0 from its neighbours; edge values w0 +- slope/2: the
        reconstruction's slope, limited so that the edges keep h >= 0 and 0 <= phi <= 1."""
        dm = w0 - wm
        dp = wp - w0
        dc = 0.5 * (wp - wm)
        # the reconstruction's slope (tiseg.solver.numerics.reconstruction)
        s = self._rec_slope(dm, dp, dc)
        # positivity of h and 0 <= phi <= 1 at the edges
        s[0] = ti.min(ti.max(s[0], -2.0 * w0[0]), 2.0 * w0[0])
        if ti.static(self.seg):
            p = w0[self.HPHI]
            lim = 2.0 * ti.min(p, 1.0 - p)
            s[self.HPHI] = ti.min(ti.max(s[self.HPHI], -lim), lim)
        return s

    @ti.kernel
    def _ghosts_primitives_slopes(self, s: ti.i32, serial: ti.template()):
        """Everything an evaluation needs from slot s before the fluxes, in one launch (each
        launch costs tens of microseconds of Python and thread start-up: on small grids
        that, not arithmetic, sets the pace). Top-level loops run in order."""
        self._ghosts(s)
        self._primitives(s, serial)
        self._slopes(serial)

    @ti.kernel
    def _ghosts_edges_slopes(self, s: ti.i32, serial: ti.template()):
        """The same when a limited combine already left the primitives of slot s's interior
        cells in w: ghost cells, their primitives, the slopes."""
        self._ghosts(s)
        self._edge_primitives(s, serial)
        self._slopes(serial)

    @ti.func
    def _primitives(self, s, serial: ti.template()):
        a, b = self.act[0], self.act[1]
        ti.loop_config(serialize=serial)
        for i, j in ti.ndrange((ti.max(a - 3, 0), ti.min(b + 3, self.NX)), (0, self.NY)):
            self.w[i, j] = self._primitive(self.q[s, i, j])

    @ti.func
    def _edge_primitives(self, s, serial: ti.template()):
        """Primitives of the ghost cells among those _primitives covers (the x range
        [a - 3, b + 3), every row); the interior ones are those _combine_cells wrote."""
        gx, nx, gy, ny = ti.static(self.gx, self.nx, self.gy, self.ny)
        a, b = self.act[0], self.act[1]
        ti.loop_config(serialize=self.strip_serial)  # 2 x 2 columns
        for k, j in ti.ndrange(gx, self.NY):
            il = gx - 1 - k
            ih = gx + nx + k
            if il >= a - 3:
                self.w[il, j] = self._primitive(self.q[s, il, j])
            if ih < b + 3:
                self.w[ih, j] = self._primitive(self.q[s, ih, j])
        if ti.static(not self.is_1d):
            ti.loop_config(serialize=serial)
            for i, k in ti.ndrange((ti.max(a - 3, gx), ti.min(b + 3, gx + nx)), gy):
                jl = gy - 1 - k
                jh = gy + ny + k
                self.w[i, jl] = self._primitive(self.q[s, i, jl])
                self.w[i, jh] = self._primitive(self.q[s, i, jh])

    @ti.func
    def _slopes(self, serial: ti.template()):
        a, b = self.act[0], self.act[1]
        if ti.static(not self.rec_first and not self.split):
            # x slopes on the interior rows of [a - 2, b + 2), y slopes on [a, b) and the
            # ghost rows next to the interior: one pass over w for both (memory, not
            # arithmetic, sets the pace of these loops on large grids)
            gy, ny = ti.static(self.gy, self.ny)
            jlo, jhi = ti.static((1, self.NY - 1) if not self.is_1d else (0, 1))
            ti.loop_config(serialize=serial)
            for i, j in ti.ndrange((ti.max(a - 2, 1), ti.min(b + 2, self.NX - 1)), (jlo, jhi)):
                w0 = self.w[i, j]
                if gy <= j < gy + ny:
                    self.sx[i, j] = self._slope(self.w[i - 1, j], w0, self.w[i + 1, j])
                if ti.static(not self.is_1d):
                    if a <= i < b:
                        self.sy[i, j] = self._slope(self.w[i, j - 1], w0, self.w[i, j + 1])

    @ti.func
    def _face_flux(self, wl, wr, d: ti.template()):
        """Numerical flux between edge states wl | wr along d: the chosen numerical flux
        (numerics.flux), then, with segregation, the h phi modifier (numerics.phi_flux); both
        components of tiseg.solver.numerics.fluxes."""
        F = self._num_flux(wl, wr, d)
        if ti.static(self._phi_modifies):
            F = self._phi_mod(F, wl, wr)
        return F

    @ti.kernel
    def _rates(self, d: ti.i32, serial: ti.template()):
        """slot d := L from the prepared primitives and slopes: face fluxes, their divergence
        plus sources, and the boundary budget rates, in one launch."""
        self._face_fluxes(serial)
        self._divergence(d, serial)
        self._boundary_rates(d)

    @ti.func
    def _face_wet(self, w0, w1, hmin, i0, j0, i1, j1):
        """Whether the face between cells (i0, j0) and (i1, j1), primitives w0 and w1, carries
        a convective flux: one of the cells is at least h_min thick; with the projected
        friction also where one of them was at the step's start (RestRules._wet_at_start).
        In the split sweeps also where one is a film (thinner) that moves, or with the
        projected friction moved at the step's start (RestRules._live_at_start). So no mass
        moves between two films at rest (a dry bed stays dry), while a film that flows
        carries its mass on: a front thins as the exact one does instead of waiting at h_min
        in each cell it enters (Physics.acts)."""
        wet = ti.max(w0[0], w1[0]) >= hmin
        if not wet:
            if ti.static(self.phys.fr_projected and self.phys.films):
                wet = self._live_at_start(i0, j0, i1, j1)
            elif ti.static(self.phys.fr_projected):
                wet = self._wet_at_start(i0, j0, i1, j1)
            elif ti.static(self.phys.films):
                wet = self._moving(w0) or self._moving(w1)
        return wet

    @ti.func
    def _moving(self, w):
        """Whether primitives w have a velocity."""
        out = w[1] != 0.0
        if ti.static(not self.is_1d):
            out = out or w[self.HV] != 0.0
        return out

    @ti.func
    def _x_face(self, i, j):
        """Flux through the face between cells (i, j) and (i + 1, j): convective plus viscous."""
        hmin = self.par[Params.H_MIN]
        w0 = self.w[i, j]
        w1 = self.w[i + 1, j]
        F = ti.Vector.zero(self.fp, self.nc)
        if self._face_wet(w0, w1, hmin, i, j, i + 1, j):
            wl = w0
            wr = w1
            if ti.static(not self.rec_first):
                wl = w0 + 0.5 * self.sx[i, j]
                wr = w1 - 0.5 * self.sx[i + 1, j]
            F = self._face_flux(wl, wr, 0)
            F = self._rest_face(F, wl, wr, 0, i, j, i + 1, j)
        if ti.static(self.visc):  # the viscous stress (tiseg.model.physics.viscosity)
            F = self._x_viscous(F, i, j, w0, w1)
        return F

    @ti.func
    def _x_viscous(self, F, i, j, w0, w1):
        """F minus the viscous stress of (6.2) through the x face (i, j) | (i + 1, j), whose
        cells' primitives are w0, w1 (the cross derivative from the rows j -+ 1 of w)."""
        ph = self.phys
        idx = self.par[Params.INV_DX]
        K = ph.face_K(w0[0], w1[0])
        F[1] -= ph.normal_stress(K, w1[1] - w0[1], idx)
        if ti.static(not self.is_1d):
            HV = ti.static(self.HV)
            idy = self.par[Params.INV_DY]
            # paired differences: exactly zero for y-independent data
            dudy = (
                (self.w[i, j + 1][1] - self.w[i, j - 1][1])
                + (self.w[i + 1, j + 1][1] - self.w[i + 1, j - 1][1])
            ) * (0.25 * idy)
            F[HV] -= ph.shear_stress(K, w1[HV] - w0[HV], idx, dudy)
        return F

    @ti.func
    def _y_face(self, i, j):
        """Flux through the face between cells (i, j) and (i, j + 1) (2D only)."""
        hmin = self.par[Params.H_MIN]
        w0 = self.w[i, j]
        w1 = self.w[i, j + 1]
        F = ti.Vector.zero(self.fp, self.nc)
        if self._face_wet(w0, w1, hmin, i, j, i, j + 1):
            wl = w0
            wr = w1
            if ti.static(not self.rec_first):
                wl = w0 + 0.5 * self.sy[i, j]
                wr = w1 - 0.5 * self.sy[i, j + 1]
            F = self._face_flux(wl, wr, 1)
            F = self._rest_face(F, wl, wr, 1, i, j, i, j + 1)
        if ti.static(self.visc):
            F = self._y_viscous(F, i, j, w0, w1)
        return F

    @ti.func
    def _y_viscous(self, F, i, j, w0, w1):
        """F minus the viscous stress of (6.2) through the y face (i, j) | (i, j + 1) (2D)."""
        HV = ti.static(self.HV)
        ph = self.phys
        idx = self.par[Params.INV_DX]
        idy = self.par[Params.INV_DY]
        K = ph.face_K(w0[0], w1[0])
        F[HV] -= ph.normal_stress(K, w1[HV] - w0[HV], idy)
        dvdx = (
            (self.w[i + 1, j][HV] - self.w[i - 1, j][HV])
            + (self.w[i + 1, j + 1][HV] - self.w[i - 1, j + 1][HV])
        ) * (0.25 * idx)
        F[1] -= ph.shear_stress(K, w1[1] - w0[1], idy, dvdx)
        return F

    @ti.func
    def _face_fluxes(self, serial: ti.template()):
        """x faces (i, i + 1) for i in [a - 1, b) on the interior rows; y faces (j, j + 1) for
        j in [gy - 1, gy + ny) on the columns [a, b). In 2D one pass does both, so each cell's
        primitives and slopes are read once per evaluation."""
        gy, ny = ti.static(self.gy, self.ny)
        a, b = self.act[0], self.act[1]
        if ti.static(self.is_1d):
            ti.loop_config(serialize=serial)
            for i, j in ti.ndrange((a - 1, b), (gy, gy + ny)):
                self.fx[i, j] = self._x_face(i, j)
        else:
            ti.loop_config(serialize=serial)
            for i, j in ti.ndrange((a - 1, b), (gy - 1, gy + ny)):
                if j >= gy:
                    self.fx[i, j] = self._x_face(i, j)
                if i >= a:
                    self.fy[i, j] = self._y_face(i, j)

    @ti.func
    def _cell_rate(self, i, j):
        """L at cell (i, j) from the face fluxes and the source: (6.1)-(6.6) in flux form;
        zero outside the active x range."""
        idx = self.par[Params.INV_DX]
        idy = self.par[Params.INV_DY]
        a, b = self.act[0], self.act[1]
        r = ti.Vector.zero(self.fp, self.nc)
        if a <= i < b:
            r = -(self.fx[i, j] - self.fx[i - 1, j]) * idx
            if ti.static(not self.is_1d):
                r -= (self.fy[i, j] - self.fy[i, j - 1]) * idy
            r += self.phys.source(self.w[i, j])
        return r

    @ti.func
    def _divergence(self, d, serial: ti.template()):
        gx, nx, gy, ny = ti.static(self.gx, self.nx, self.gy, self.ny)
        a, b = self.act[0], self.act[1]
        # rates on the active range and zero on the 3 cells either side that _combine also
        # reads; further out nothing reads them while this range holds (see _combine)
        ti.loop_config(serialize=serial)
        for i, j in ti.ndrange((ti.max(a - 3, gx), ti.min(b + 3, gx + nx)), (gy, gy + ny)):
            self.q[d, i, j] = self._cell_rate(i, j)

    # ------------------------------------------------------------------ stepper interface
    def _prepare(self, slot: int, t: float) -> None:
        """Ghost cells, primitives and slopes of ``slot`` at time t, unless still current.

        A step measures its stability numbers on slot 0 and then evaluates L(slot 0) at the same
        time: the second preparation is skipped (about a third of an evaluation). A limited
        combine leaves its result's interior primitives in w, so preparing that slot next
        computes only the ghost cells' ones. Any write to the slot, a parameter change or a
        new active range makes these caches stale."""
        key = (slot, t, self.active)
        if self._prepared != key:
            self._set_time(t)
            if self._interior == (slot, self.active):
                self._ghosts_edges_slopes(slot, self.serial_loops())
            else:
                self._ghosts_primitives_slopes(slot, self.serial_loops())
            self._prepared = key
        if self.rest is not None and self._rest_stale:  # a step begins: slot 0 was written
            self._mark_rest(self.serial_loops())
            self._rest_stale = False
            self._first_stage = True
            self._mask_inflow = self.inflow_on(t)

    def _written(self, dst: int, primitives: bool = False) -> None:
        """Slot dst changed; with ``primitives`` its interior primitives are now in w."""
        if dst == 0:
            self._rest_stale = True
        if primitives:
            self._prepared = None
            self._interior = (dst, self.active)
            return
        if self._prepared is not None and self._prepared[0] == dst:
            self._prepared = None
        if self._interior is not None and self._interior[0] == dst:
            self._interior = None

    def _no_operator(self) -> None:
        if self.split:
            raise TisegError(
                "numerics.stepper 'hancock' advances by sweeps (tiseg.solver.numerics.split) and "
                "has no semi-discrete operator L to evaluate"
            )

    def rhs(self, src: int, dst: int, t: float) -> None:
        """slot dst := L(slot src, t) on interior cells (fills src's ghost cells)."""
        self._no_operator()
        self._prepare(src, t)
        self._written(dst)
        self._rates(dst, self.serial_loops())

    def sums(self, slot: int = 0) -> tuple[float, float]:
        """(sum of h, sum of h phi) over interior cells, deterministic, in f64."""
        return self.reduce.totals(slot, self.serial_loops(whole=True))

    def set_active(self, a: int, b: int, wet: tuple[int, int] | None = None) -> None:
        """Restrict the operator to interior x indices [a, b) (array indices, ghosts counted).
        ``wet``: the range [wa, wb) the next wet scan covers (_wet_extent), which holds [a, b);
        by default [a, b) itself. It is wider where resting regions are left out
        (ActiveRange.set)."""
        if not self.ranges.set(a, b, wet):
            return  # each field write from Python is a kernel launch
        self._prepared = self._interior = None
        if getattr(self, "rest", None) is not None and self._first_stage:
            # the step's rest mask was taken on the old range (_mark_rest: act +- 4) and the
            # step has not begun: take it again on the new one (slot 0 is the same), or
            # cells the range now takes in would keep bits of an earlier step, or none
            self._rest_stale = True

    @property
    def active(self) -> tuple[int, int]:
        """The active x range [a, b) (ActiveRange)."""
        return self.ranges.active

    @property
    def wet_range(self) -> tuple[int, int]:
        """The x range [wa, wb) the next wet scan covers (ActiveRange)."""
        return self.ranges.wet_range

    @property
    def force_serial(self) -> bool | None:
        return self.ranges.force_serial

    def serial_loops(self, whole: bool = False) -> bool:
        """Whether the next launch runs its loops on one thread (ActiveRange.serial_loops):
        both modes give the same bits (tests/test_determinism.py)."""
        return self.ranges.serial_loops(whole)

    def inflow_on(self, t: float) -> bool:
        """Whether an inflow runs at time t (until the scene's inflow stop time)."""
        return self.bc[0] == "inflow" and not t > self.cfg.inflow_stop

    def stability(self, slot: int, t: float) -> StabilityNumbers:
        """Wave speeds and stiffness bounds of ``slot`` at time t (StepReductions.stability)."""
        self._prepare(slot, t)
        return self.reduce.stability(self.serial_loops())
