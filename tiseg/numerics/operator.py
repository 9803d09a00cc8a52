"""The semi-discrete operator dq/dt = L(q, t) of (6.1)-(6.6) in Taichi kernels.

Same discretisation as the NumPy reference (:mod:`tiseg.reference.operator`, whose docstring
lists the steps): ghost cells, desingularised primitives, slopes (first order / minmod-theta /
WENO-type), Kurganov-Tadmor or central-upwind fluxes with local speeds (optionally with the
h phi flux upwinded by the mass flux), the viscous stress with harmonic face coefficients, and
the friction source.

States live in one field ``q`` of ``nslots`` slots (Taichi compiles one kernel per distinct field
passed as template, so buffers are slots selected by an integer). Time steppers
(:mod:`tiseg.timestepping`) see only :meth:`rhs`, :meth:`combine` (with the stage limiter) and
:meth:`stability`.
"""

from dataclasses import dataclass

import numpy as np
import taichi as ti

from .. import backend
from ..field_tree import FieldTree
from ..physics.pointwise import Params, Physics, param_count, param_values
from .boundaries import BOUNDARIES
from .config import OperatorConfig
from .fluxes import FLUXES, PHI_FLUXES
from .reconstruction import RECONSTRUCTIONS
from .split import SplitSweeps

MAX_TERMS = 6
NBUDGET = 4  # mass in through x faces, small mass x, mass y, small mass y
# bits of the rest mask (projected friction), set at a step's start (_mark_rest, _project)
REST = 1  # u = v = 0 exactly
HELD = 2  # the static friction holds the cell for the whole step (laws with hysteresis)
X_POS, X_NEG, Y_POS, Y_NEG = 4, 8, 16, 32  # moving with u > 0, u < 0, v > 0, v < 0


@dataclass
class StabilityNumbers:
    ax: float  # max |u| + c (or segregation speed) in x [m/s]
    ay: float
    rho_visc: float  # Gershgorin bound of the viscous Jacobian [1/s]
    rho_fric: float  # friction stiffness [1/s]
    max_speed: float  # max |u| [m/s]
    rho_stiff: float  # Gershgorin bound of viscous + friction together: max over cells of the
    # sum, <= rho_visc + rho_fric (they peak in different cells) [1/s]
    # step_rule "local" (2D): max over cells of a_x/dx + a_y/dy, each speed the largest of the
    # cell and its two neighbours along that direction [1/s]; None where not computed
    rate_local: float | None = None


NSTAB = 7  # numbers the stability pass reduces (red): the fields above, in order


# Below this many cells a CPU launch runs its loops on the calling thread. Each parallel loop
# costs a fixed ~80 us on the 2-core machines here (the thread pool's hand-off, measured with a
# one-line kernel; a serialised loop costs ~1 us), and an evaluation has about ten of them: on
# small grids that, not arithmetic, set the pace. Each kernel is compiled for both modes (a
# template argument) and the choice is made per launch from the cells it covers (the active x
# range), so a fingers run goes serial while its front is short and parallel once it is long.
# The crossover measured on 2 threads (benchmarks/README.md section 7): 50-75k cells.
SERIAL_CELLS = 60_000


@ti.data_oriented
class TaichiOperator(SplitSweeps):
    def __init__(self, cfg: OperatorConfig, nslots: int = 6, serial: bool | None = None):
        """``serial``: run every loop on the calling thread (True), never (False), or decide
        per launch (None, :meth:`serial_loops`); the results are the same bits either way."""
        st = backend.state()
        self.generation = st.generation
        self.cfg = cfg
        lay = cfg.layout
        self.lay = lay
        self.nslots = nslots
        self.fp = ti.f64 if st.precision == "f64" else ti.f32
        self._stability = self._stability_f64 if st.precision == "f64" else self._stability_f32
        self.np_fp = np.float64 if st.precision == "f64" else np.float32
        nc, NX, NY = lay.nc, lay.NX, lay.NY
        # compile-time constants
        self.nc, self.NX, self.NY = nc, NX, NY
        self.nx, self.ny, self.gx, self.gy = lay.nx, lay.ny, lay.gx, lay.gy
        self.is_1d, self.seg, self.visc = lay.is_1d, lay.segregation, cfg.viscous
        self.H, self.HU, self.HV, self.HPHI = lay.H, lay.HU, lay.HV, lay.HPHI
        # the numerics components (tiseg.numerics.reconstruction, .fluxes, .boundaries): their
        # Taichi functions are built once the fields exist (_compose)
        self.rec = RECONSTRUCTIONS[cfg.reconstruction]
        self.rec_first = not self.rec.slopes
        self.num_flux = FLUXES[cfg.flux]
        self.phi_flux = PHI_FLUXES[cfg.phi_flux]
        self.local_rate = bool(cfg.local_step_rate) and not self.is_1d
        # the split scheme (numerics.stepper "hancock", tiseg.numerics.split): sweeps instead
        # of evaluations of L, with their own edge fields and no stored slopes
        self.split = bool(cfg.split)
        self.bc = tuple(cfg.bc)
        self.bcs = tuple(BOUNDARIES[b] for b in cfg.bc)  # x_lo, x_hi, y_lo, y_hi
        # serial loops: forced (True/False), or chosen from the cells a launch covers; the
        # choice for the active range is made when the range is set (set_active)
        self.force_serial = None if serial is None else bool(serial)
        self._threads = st.threads or backend.available_cores()
        self._on_cpu = st.arch == "cpu"
        self._serial_whole = self._serial_for(NX * NY)
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
        # step_rule "local": each cell's wave speeds along x and y, for the stability pass
        self.spd = ft.vector(2, self.fp, (NX, NY)) if self.local_rate else None
        # inflow concentration per cross-slope cell: only with an inflow that carries phi
        self.inflow_prof = ft.field(self.fp, NY) if self.seg and cfg.bc[0] == "inflow" else None
        self.red = ft.field(self.fp, NSTAB)
        # Active range [a, b) of x indices whose cells may change. Cells outside are dry films
        # (h < h_min) far from any wet cell: their rhs is exactly zero, so skipping them is exact.
        self.act = ft.field(ti.i32, 2)
        self.rowsum = ft.field(ti.f64, (NX, 2))
        # rows reduced by one thread before one atomic (_stability, _wet_extent): a row in 2D,
        # 256 cells in 1D (one row of NX cells), where per-cell atomics would contend
        self.rows_per_block = max(1, 256 // NY)
        self.total = ft.field(ti.f64, 2)
        # first and last x index of a wet cell, then of a live one (_wet_extent)
        self.wet = ft.field(ti.i32, 4)
        # the x range the wet scan covers (besides the halo): the wet cells and their margin,
        # which contains the active range act and, with resting regions skipped, more
        self.wrng = ft.field(ti.i32, 2)
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
        self._rest_stale = True
        # A law with hysteresis holds resting cells exactly for a whole step (HELD): columns
        # of such cells far from any moving one then need no work at all, and the active range
        # leaves them out (_quiescent, Simulation._set_active). Decided from the rest mask of
        # the step before, so the mask is part of the run's state (checkpoints keep it).
        self.skip_rest = bool(self.phys.fr_projected and self.phys.law.hysteresis)
        self._first_stage = False  # the next limited combination is a step's first stage
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
            from ..errors import TisegError

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
        side's component (tiseg.numerics.boundaries) fills its cells, low side first."""
        gx, gy = ti.static(self.gx, self.gy)
        ti.loop_config(serialize=True)  # 2 columns of cells: never worth a hand-off
        for k, j in ti.ndrange(gx, (0, self.NY)):
            self._fill[0](s, k, j)
            self._fill[1](s, k, j)
        if ti.static(not self.is_1d):
            ti.loop_config(serialize=True)  # 2 rows of cells
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
        # the reconstruction's slope (tiseg.numerics.reconstruction)
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
        ti.loop_config(serialize=True)  # 2 x 2 columns
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
        components of tiseg.numerics.fluxes."""
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
    def _rest_face(self, F, wl, wr, d: ti.template(), i0, j0, i1, j1):
        """With the projected friction scheme, the mass (and h phi) flux at a face next to a
        cell at rest. "At rest" is read from the step's initial state (_mark_rest), not from
        the stage's: a cell that the first stage stops must not switch its faces off for the
        later ones. The rates of a step are then one smooth function, which RKC's stage
        weights (of both signs, ~2 and -1.6 at 2 stages) rely on; switching mid-step emptied a
        thin cell next to a deposit below zero, and the limiter's clip then created mass.

        * Between two cells at rest no mass crosses: the central schemes' dissipation
          a/2 (h_r - h_l) would otherwise let a deposit's surface relax for ever. The
          momentum flux stays (the pressure), and the friction projection decides whether
          the cells start to move.
        * Where the upwind cell moves towards its neighbour (u_n > 0 on the left, or < 0 on
          the right, at the step's start) and the neighbour does not move against it, at
          least F_h >= f_u - f_d^2 / f_u crosses, f_u = h_l max(u_l, 0) the upwind cell's own
          flux and f_d = h_r max(u_r, 0) the downwind cell's the same way (edge states;
          mirrored for a right-hand upwind cell), with h phi carried at the upwind cell's
          phi. Into a cell at rest that is the upwind cell's whole flux; between cells of the
          same flux it is zero; into a slow cell it falls short of f_u by f_d^2 / f_u only.
          The central flux's dissipation a/2 (h_r - h_l), which at low Froude numbers is
          most of its mass flux, would
          otherwise draw mass back out of a thicker, slower or resting neighbour against the
          flow: thin films flowing into a deposit, and short chains of slow cells, were held
          in place by it and kept a speed of mm/s for ever while no mass moved. In a flow
          whose flux does not collapse from one cell to the next the bound lies below the
          central flux and changes nothing; the momentum flux stays the central one."""
        out = F
        if ti.static(self.phys.fr_projected):
            r0 = ti.cast(self.rest[i0, j0], ti.i32)
            r1 = ti.cast(self.rest[i1, j1], ti.i32)
            if (r0 & REST) != 0 and (r1 & REST) != 0:
                out[0] = 0.0
                if ti.static(self.seg):
                    out[self.HPHI] = 0.0
            else:
                # at least the flux by which the upwind cell outruns its neighbour
                pos = ti.static(X_POS if d == 0 else Y_POS)
                neg = ti.static(X_NEG if d == 0 else Y_NEG)
                if (r0 & pos) != 0 and (r1 & neg) == 0:
                    out = self._flux_floor(out, wl, wr, d, 1.0)
                elif (r1 & neg) != 0 and (r0 & pos) == 0:
                    out = self._flux_floor(out, wr, wl, d, -1.0)
        return out

    @ti.func
    def _flux_floor(self, F, wu, wd, d: ti.template(), s: ti.template()):
        """F with its mass flux raised (s = 1, upwind cell on the left) or lowered (s = -1, on
        the right) to s (f_u - f_d^2 / f_u) where that is beyond it: f_u = h max(s u_n, 0) of
        the upwind edge state wu, f_d the same of the downwind one wd; h phi then moves at
        the upwind cell's phi (_rest_face)."""
        out = F
        c = ti.static(1 if d == 0 else self.HV)
        fu = wu[0] * ti.max(s * wu[c], 0.0)
        fd = wd[0] * ti.max(s * wd[c], 0.0)
        # f_u - f_d^2 / f_u > s F  <=>  f_u^2 - f_d^2 > s F f_u (f_u > 0): the division only
        # where the floor applies, which in a flow is rare (a division on every face cost ~2 %)
        if fu > 0.0 and fu * fu - fd * fd > s * out[0] * fu:
            b = s * (fu - fd * fd / fu)
            if s * b > s * out[0]:  # never false but at a tie of rounding
                out[0] = b
                if ti.static(self.seg):
                    out[self.HPHI] = b * self.phys.transported(wu[self.HPHI])
        return out

    @ti.kernel
    def _mark_rest(self, serial: ti.template()):
        """rest := REST where the prepared primitives have u = v = 0, else the signs of u and v
        (X_POS / X_NEG, Y_POS / Y_NEG), on the cells the faces near the active range read
        (further out no face flux is computed). With a law with hysteresis the step's first
        stage then adds HELD to the cells the static friction holds (_project)."""
        lo = ti.max(self.act[0] - 4, 0)
        hi = ti.min(self.act[1] + 4, self.NX)
        ti.loop_config(serialize=serial)
        for i, j in ti.ndrange((lo, hi), (0, self.NY)):
            w = self.w[i, j]
            r = w[1] == 0.0
            if ti.static(not self.is_1d):
                r = r and w[self.HV] == 0.0
            flag = 0
            if r:
                flag = REST
            else:
                if w[1] > 0.0:
                    flag |= X_POS
                elif w[1] < 0.0:
                    flag |= X_NEG
                if ti.static(not self.is_1d):
                    if w[self.HV] > 0.0:
                        flag |= Y_POS
                    elif w[self.HV] < 0.0:
                        flag |= Y_NEG
            self.rest[i, j] = ti.cast(flag, ti.i8)

    @ti.func
    def _x_face(self, i, j):
        """Flux through the face between cells (i, j) and (i + 1, j): convective plus viscous."""
        hmin = self.par[Params.H_MIN]
        idx = self.par[Params.INV_DX]
        w0 = self.w[i, j]
        w1 = self.w[i + 1, j]
        F = ti.Vector.zero(self.fp, self.nc)
        if ti.max(w0[0], w1[0]) >= hmin:
            wl = w0
            wr = w1
            if ti.static(not self.rec_first):
                wl = w0 + 0.5 * self.sx[i, j]
                wr = w1 - 0.5 * self.sx[i + 1, j]
            F = self._face_flux(wl, wr, 0)
            F = self._rest_face(F, wl, wr, 0, i, j, i + 1, j)
        if ti.static(self.visc):  # the viscous stress (tiseg.physics.viscosity)
            ph = self.phys
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
        HV = ti.static(self.HV)
        w0 = self.w[i, j]
        w1 = self.w[i, j + 1]
        F = ti.Vector.zero(self.fp, self.nc)
        if ti.max(w0[0], w1[0]) >= hmin:
            wl = w0
            wr = w1
            if ti.static(not self.rec_first):
                wl = w0 + 0.5 * self.sy[i, j]
                wr = w1 - 0.5 * self.sy[i, j + 1]
            F = self._face_flux(wl, wr, 1)
            F = self._rest_face(F, wl, wr, 1, i, j, i, j + 1)
        if ti.static(self.visc):
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

    @ti.func
    def _limit(self, v):
        """The stage limiter: h >= 0, no momentum in films thinner than h_min, 0 <= h phi <= h."""
        h = ti.select(v[0] < 0.0, 0.0, v[0])  # unlike max(), lets a NaN through to the guard
        v[0] = h
        if h < self.par[Params.H_MIN]:
            v[1] = 0.0
            if ti.static(not self.is_1d):
                v[self.HV] = 0.0
        if ti.static(self.seg):
            v[self.HPHI] = ti.min(ti.max(v[self.HPHI], 0.0), h)
        return v

    @ti.kernel
    def _combine(
        self,
        d: ti.i32,
        n: ti.template(),
        rate: ti.template(),
        limit: ti.template(),
        c0: float,
        c1: float,
        c2: float,
        c3: float,
        c4: float,
        c5: float,
        s0: ti.i32,
        s1: ti.i32,
        s2: ti.i32,
        s3: ti.i32,
        s4: ti.i32,
        s5: ti.i32,
        tau: float,
        rmask: ti.template(),
        first: ti.template(),
        serial: ti.template(),
    ):
        """slot d := sum of c_k * term k (k < n), then the stage limiter if ``limit``, on the
        active x range widened by the 3 cells either side that the next evaluation's stencil
        reads (see _combine_cells). Term k is slot s_k, except term ``rate`` (if >= 0): L of
        the prepared state, computed in this launch (face fluxes first, their boundary rates
        into the spare budget row) and used where it is computed, never stored: a fused stage
        makes two passes over the grid fewer than _rates followed by a combination.

        The coefficients come as kernel arguments: writing them into a field from Python
        costs a launch each, which dominated small grids."""
        cs = ti.Vector([c0, c1, c2, c3, c4, c5])
        ss = ti.Vector([s0, s1, s2, s3, s4, s5], dt=ti.i32)
        if ti.static(rate >= 0):
            self._face_fluxes(serial)
            self._boundary_rates(self.nslots)
        self._combine_cells(d, n, rate, limit, cs, ss, tau, rmask, first, serial)

    @ti.func
    def _combine_cells(
        self,
        d,
        n: ti.template(),
        rate: ti.template(),
        limit: ti.template(),
        cs,
        ss,
        tau,
        rmask: ti.template(),
        first: ti.template(),
        serial: ti.template(),
    ):
        """slot d := sum of c_k * term k, term k being slot s_k, or for k == ``rate`` (>= 0)
        L at the cell (_cell_rate); then the stage limiter if ``limit``, which also leaves the
        result's primitives in w (the next evaluation is of slot d). The sum runs in the order
        of the terms, so a fused stage gives the bits of _rates followed by _combine.

        Cells: the active x range widened by the 3 cells either side that the next
        evaluation's stencil reads. Why that is enough: the active range is fixed for the
        whole step (set_active runs between steps), every rate is zero on the widened range
        outside the active one (_cell_rate), and the first stage combines from slot 0, which
        is valid everywhere. So within a step every slot is valid on the widened range, and
        nothing beyond it is read. Cells further out are dry films that the step does not
        change; skipping them saves two passes over the dry chute per stage.

        A cell's rate reads the face fluxes and its own primitives only, so d may be the slot
        the rate is of, or any of the sources: the update is element-wise.

        With the projected friction scheme the limiter is followed by the friction projection
        over ``tau``, the stage's share of the step (_project), and by _keep_rest; bit k of
        ``rmask`` marks term k as a stored rate rather than a state; ``first``: this is the
        step's first stage (its static-friction decisions are made here)."""
        gx, nx, gy, ny = ti.static(self.gx, self.nx, self.gy, self.ny)
        lo = ti.max(self.act[0] - 3, gx)
        hi = ti.min(self.act[1] + 3, gx + nx)
        ti.loop_config(serialize=serial)
        for i, j in ti.ndrange((lo, hi), (gy, gy + ny)):
            r = ti.Vector.zero(self.fp, self.nc)
            # the speed of the state the stage starts from (the prepared one): the friction
            # coefficient of the projection (Physics.project_friction)
            spd0 = 0.0 * r[0]
            if ti.static(limit and self.phys.fr_projected):
                spd0 = self.phys.speed_mag(self.w[i, j])
            if ti.static(rate >= 0):
                r = self._cell_rate(i, j)
            acc = ti.Vector.zero(self.fp, self.nc)
            for k in ti.static(range(n)):
                term = r if ti.static(k == rate) else self.q[ss[k], i, j]
                if ti.static(k == 0):
                    acc = cs[0] * term
                else:
                    acc += cs[k] * term
            if ti.static(limit):
                acc = self._limit(acc)
                if ti.static(self.phys.fr_projected):
                    acc = self._project(acc, tau, i, j, first, spd0)
                    acc = self._keep_rest(acc, r, i, j, n, rate, rmask, ss)
                self.w[i, j] = self._primitive(acc)
            self.q[d, i, j] = acc
        ti.loop_config(serialize=True)  # a handful of iterations
        for b in range(NBUDGET):
            acc = 0.0 * cs[0]
            for k in ti.static(range(n)):
                bk = self.bud[self.nslots, b] if ti.static(k == rate) else self.bud[ss[k], b]
                if ti.static(k == 0):
                    acc = cs[0] * bk
                else:
                    acc += cs[k] * bk
            self.bud[d, b] = acc

    @ti.func
    def _project(self, acc, tau, i, j, first: ti.template(), spd0):
        """The friction projection of a stage's result (Physics.project_friction, with the
        coefficient at ``spd0``, the speed of the state the stage started from). With a law
        with hysteresis the static friction decides once per step, on its first stage, which
        of the cells at rest at the step's start it holds (Physics.holds, marked HELD in rest): a
        held cell stays exactly at rest through all the step's stages, every other cell is
        projected. Deciding per stage instead made the starts depend on the step length and
        on RKC's stage weights (signed: a cell that stage 1 started, stage 2 could stop)."""
        out = acc
        if ti.static(self.phys.law.hysteresis):
            flag = ti.cast(self.rest[i, j], ti.i32)
            if ti.static(first):
                # nested, not `and`: Taichi's `and` evaluates both sides, and holds() (the start
                # coefficient mu_S) on every moving cell cost ~5 % of a fingers step
                if (flag & REST) != 0:
                    if self.phys.holds(acc, tau) == 1:
                        flag |= HELD
                        self.rest[i, j] = ti.cast(flag, ti.i8)
            if (flag & HELD) != 0:
                out[1] = 0.0
                if ti.static(not self.is_1d):
                    out[self.HV] = 0.0
            else:
                out = self.phys.project_friction(acc, tau, spd0)
        else:
            out = self.phys.project_friction(acc, tau, spd0)
        return out

    @staticmethod
    def _first_state(n: int, rate: int, rmask: int) -> int:
        return next(k for k in range(n) if k != rate and not (rmask >> k) & 1)

    @ti.func
    def _keep_rest(
        self, acc, r, i, j, n: ti.template(), rate: ti.template(), rmask: ti.template(), ss
    ):
        """A cell at rest after the projection whose state terms all hold the same h and h phi
        and whose rates of h and h phi are all zero (no mass crossed its faces: _x_face) keeps
        that h and h phi bitwise: the stage weights of the states sum to 1, but their rounded
        sum need not give the same bits, and a deposit must not creep by round-off."""
        f = ti.static(self._first_state(n, rate, rmask))
        out = acc
        moving = acc[1] != 0.0
        if ti.static(not self.is_1d):
            moving = moving or acc[self.HV] != 0.0
        # a moving cell (most of a flow) reads no term again: the test costs one branch there
        if not moving:
            ref = self.q[ss[f], i, j]
            keep = 1
            for k in ti.static(range(n)):
                if ti.static(k == rate):
                    if r[0] != 0.0:
                        keep = 0
                    if ti.static(self.seg):
                        if r[self.HPHI] != 0.0:
                            keep = 0
                elif ti.static((rmask >> k) & 1):
                    v = self.q[ss[k], i, j]
                    if v[0] != 0.0:
                        keep = 0
                    if ti.static(self.seg):
                        if v[self.HPHI] != 0.0:
                            keep = 0
                elif ti.static(k != f):
                    v = self.q[ss[k], i, j]
                    if v[0] != ref[0]:
                        keep = 0
                    if ti.static(self.seg):
                        if v[self.HPHI] != ref[self.HPHI]:
                            keep = 0
            if keep == 1:
                out[0] = ref[0]
                if ti.static(self.seg):
                    out[self.HPHI] = ref[self.HPHI]
        return out

    @ti.kernel
    def _blend(self, d: ti.i32, a: ti.i32, b: ti.i32, theta: float, serial: ti.template()):
        """slot d := (1 - theta) slot a + theta slot b on every cell, ghosts included, and the
        same for the budgets (no active range: a copy must be whole). Written a + theta (b - a),
        which gives a's bits where b == a: a deposit at rest then has the same h in every
        snapshot, as it has in the step states ((1 - theta) a + theta a can be an ulp off)."""
        ti.loop_config(serialize=serial)
        for i, j in ti.ndrange(self.NX, self.NY):
            qa = self.q[a, i, j]
            self.q[d, i, j] = qa + theta * (self.q[b, i, j] - qa)
        ti.loop_config(serialize=True)  # a handful of iterations
        for k in range(NBUDGET):
            self.bud[d, k] = self.bud[a, k] + theta * (self.bud[b, k] - self.bud[a, k])

    @ti.func
    def _boundary_rates(self, d):
        """Net inflow rates through the domain's faces, summed in a fixed order."""
        gx, nx, gy, ny = ti.static(self.gx, self.nx, self.gy, self.ny)
        dx = self.par[Params.DX]
        dy = self.par[Params.DY]
        ti.loop_config(serialize=True)
        for b in range(NBUDGET):
            self.bud[d, b] = 0.0
        # faces outside the active range were not computed this time: they carry no flux
        wl = 1.0 if self.act[0] == gx else 0.0
        wr = 1.0 if self.act[1] == gx + nx else 0.0
        ti.loop_config(serialize=True)
        for j in range(gy, gy + ny):
            self.bud[d, 0] += (wl * self.fx[gx - 1, j][0] - wr * self.fx[gx + nx - 1, j][0]) * dy
            if ti.static(self.seg):
                self.bud[d, 1] += (
                    wl * self.fx[gx - 1, j][self.HPHI] - wr * self.fx[gx + nx - 1, j][self.HPHI]
                ) * dy
        if ti.static(not self.is_1d):
            ti.loop_config(serialize=True)
            for i in range(self.act[0], self.act[1]):
                self.bud[d, 2] += (self.fy[i, gy - 1][0] - self.fy[i, gy + ny - 1][0]) * dx
                if ti.static(self.seg):
                    self.bud[d, 3] += (
                        self.fy[i, gy - 1][self.HPHI] - self.fy[i, gy + ny - 1][self.HPHI]
                    ) * dx

    # The return type must follow the run's precision. A type built from ``float`` is fixed
    # when this module is imported, i.e. before tiseg.init chooses the precision (Taichi's
    # default is f32), which rounded every f64 run's step limits to f32. One kernel per
    # precision, chosen in __init__; only the chosen one is ever compiled (Metal has no f64).
    @ti.kernel
    def _stability_f64(self, serial: ti.template()) -> ti.types.vector(NSTAB, ti.f64):
        return self._stability_body(serial)

    @ti.kernel
    def _stability_f32(self, serial: ti.template()) -> ti.types.vector(NSTAB, ti.f32):
        return self._stability_body(serial)

    @ti.func
    def _stability_body(self, serial: ti.template()):
        """Max wave speeds, Gershgorin bound of the viscous Jacobian and friction stiffness
        from the primitives of the current state. Blocks of rows run in parallel and reduce
        locally, so there is one atomic per block (maxima are order independent:
        deterministic); a block is one row in 2D and 256 cells of the row in 1D, where an
        atomic per cell would serialise the threads on one address.

        The friction Jacobian is local to a cell (a 2 x 2 block in (hu, hv) bounded by the
        friction rate), so it adds to the diagonal of that cell's viscous rows: Gershgorin's
        theorem bounds the spectrum of both terms together by the largest per-cell sum
        (red[5]). The friction peaks in slow thin margins and levees, the viscosity in thick
        fast channels, so the sum of the two maxima (red[2] + red[3]) overestimates it by up
        to 2x, and the RKC stage count with it.

        With step_rule "local" (2D) red[6] is the largest per-cell convective rate
        max(a_x over i-1..i+1)/dx + max(a_y over j-1..j+1)/dy: the speeds of the faces of the
        cell, which bound the forward-Euler step that keeps that cell's h >= 0 (see
        tiseg.simulation.step_limits). Only such runs compute it."""
        gx, nx, gy, ny = ti.static(self.gx, self.nx, self.gy, self.ny)
        ti.loop_config(serialize=True)  # a handful of iterations
        for k in range(NSTAB):
            self.red[k] = 0.0
        hmin = self.par[Params.H_MIN]
        idx = self.par[Params.INV_DX]
        idy = self.par[Params.INV_DY]
        # include the first ghost layer in x so that an inflow into an empty chute sets a speed
        lo = ti.max(self.act[0] - 1, gx - 1)
        hi = ti.min(self.act[1] + 1, gx + nx + 1)
        B = ti.static(self.rows_per_block)
        if ti.static(self.local_rate):
            # each cell's (a_x, a_y) once, neighbours and ghost rows included: the rate reads
            # 5 speeds per cell, and recomputing them (a square root each) cost 10 % of a
            # Stoker step on one thread
            ti.loop_config(serialize=serial)
            for i, j in ti.ndrange((lo - 1, hi + 1), (0, self.NY)):
                w = self.w[i, j]
                self.spd[i, j] = ti.Vector([self.phys.speed(w, 0), self.phys.speed(w, 1)])
        ti.loop_config(serialize=serial)
        for blk in range((hi - lo + B - 1) // B):
            m0 = 0.0
            m1 = 0.0
            m2 = 0.0
            m3 = 0.0
            m4 = 0.0
            m5 = 0.0
            m6 = 0.0
            for r in range(B):
                i = lo + blk * B + r
                if i < hi:
                    for j in range(gy, gy + ny):
                        w = self.w[i, j]
                        if ti.static(self.local_rate):
                            sp = self.spd[i, j]
                            m0 = ti.max(m0, sp[0])
                            m1 = ti.max(m1, sp[1])
                            axm = ti.max(
                                ti.max(self.spd[i - 1, j][0], sp[0]), self.spd[i + 1, j][0]
                            )
                            aym = ti.max(
                                ti.max(self.spd[i, j - 1][1], sp[1]), self.spd[i, j + 1][1]
                            )
                            m6 = ti.max(m6, axm * idx + aym * idy)
                        else:
                            m0 = ti.max(m0, self.phys.speed(w, 0))
                            if ti.static(not self.is_1d):
                                m1 = ti.max(m1, self.phys.speed(w, 1))
                        m4 = ti.max(m4, self.phys.speed_mag(w))
                        fr = self.phys.friction_rate(w)
                        m3 = ti.max(m3, fr)
                        rho = 0.0 * fr
                        if ti.static(self.visc):
                            h = w[0]
                            if h >= hmin and gx <= i < gx + nx:
                                hn = h  # (not read in 1D)
                                hs = h
                                if ti.static(not self.is_1d):
                                    hn = self.w[i, j + 1][0]
                                    hs = self.w[i, j - 1][0]
                                rho = self.phys.visc_stiffness(
                                    h,
                                    self.w[i + 1, j][0],
                                    self.w[i - 1, j][0],
                                    hn,
                                    hs,
                                    idx,
                                    idy,
                                )
                                m2 = ti.max(m2, rho)
                        m5 = ti.max(m5, rho + fr)
            ti.atomic_max(self.red[0], m0)
            ti.atomic_max(self.red[1], m1)
            ti.atomic_max(self.red[2], m2)
            ti.atomic_max(self.red[3], m3)
            ti.atomic_max(self.red[4], m4)
            ti.atomic_max(self.red[5], m5)
            ti.atomic_max(self.red[6], m6)
        return ti.Vector([self.red[k] for k in ti.static(range(NSTAB))])

    @ti.kernel
    def _totals(self, s: ti.i32, serial: ti.template()) -> ti.types.vector(2, ti.f64):
        """Sums of h and h phi over interior cells in a fixed order (rows in parallel, each
        summed serially, then the rows serially): the same bits for any thread count."""
        gx, nx, gy, ny = ti.static(self.gx, self.nx, self.gy, self.ny)
        self.total[0] = 0.0
        self.total[1] = 0.0
        ti.loop_config(serialize=serial)
        for i in range(gx, gx + nx):
            a = ti.cast(0.0, ti.f64)
            b = ti.cast(0.0, ti.f64)
            for j in range(gy, gy + ny):
                v = self.q[s, i, j]
                a += ti.cast(v[0], ti.f64)
                if ti.static(self.seg):
                    b += ti.cast(v[self.HPHI], ti.f64)
            self.rowsum[i, 0] = a
            self.rowsum[i, 1] = b
        ti.loop_config(serialize=True)
        for i in range(gx, gx + nx):
            self.total[0] += self.rowsum[i, 0]
            self.total[1] += self.rowsum[i, 1]
        return ti.Vector([self.total[0], self.total[1]])

    @ti.kernel
    def _wet_extent(self, s: ti.i32, serial: ti.template()) -> ti.types.vector(4, ti.i32):
        """Ghost cells of slot s, then the smallest and largest x index (ghosts included) of a
        cell with h >= h_min, and of a live cell (see _quiescent), returned (one launch, no
        field read-back).

        Only the x range [wa - 3, wb + 3) around the wet range is scanned for wet cells: every
        cell outside it is a dry film (the wet range is the wet extent plus a margin, and a
        step writes nothing further out), and whatever could put wet cells there (set,
        set_params) makes the ranges whole again. A fingers run's early steps then scan the
        front, not the empty chute. Live cells are looked for on the range the last step
        wrote, [a - 3, b + 3) around the active range: every cell beyond it was quiescent when
        it was left out, and nothing has touched it since."""
        self._ghosts(s)
        self.wet[0] = self.NX
        self.wet[1] = -1
        self.wet[2] = self.NX
        self.wet[3] = -1
        hmin = self.par[Params.H_MIN]
        lo = ti.max(self.wrng[0] - 3, 0)
        hi = ti.min(self.wrng[1] + 3, self.NX)
        # the live scan: interior cells only (their neighbours, ghosts included, are read)
        llo = ti.max(self.act[0] - 3, self.gx)
        lhi = ti.min(self.act[1] + 3, self.gx + self.nx)
        B = ti.static(self.rows_per_block)
        ti.loop_config(serialize=serial)
        for blk in range((hi - lo + B - 1) // B):
            first = self.NX
            last = -1
            lfirst = self.NX
            llast = -1
            for r in range(B):
                i = lo + blk * B + r
                if i < hi:
                    scan_live = llo <= i < lhi
                    for j in range(self.gy, self.gy + self.ny):
                        if self.q[s, i, j][0] >= hmin:
                            first = ti.min(first, i)
                            last = ti.max(last, i)
                        if ti.static(self.skip_rest):
                            if scan_live:
                                if self._quiescent(s, i, j, hmin) == 0:
                                    lfirst = ti.min(lfirst, i)
                                    llast = ti.max(llast, i)
            if last >= 0:  # one atomic per block of rows (see _stability)
                ti.atomic_min(self.wet[0], first)
                ti.atomic_max(self.wet[1], last)
            if llast >= 0:
                ti.atomic_min(self.wet[2], lfirst)
                ti.atomic_max(self.wet[3], llast)
        return ti.Vector([self.wet[0], self.wet[1], self.wet[2], self.wet[3]])

    @ti.func
    def _quiescent(self, s, i, j, hmin):
        """1 where cell (i, j) sat out the last step exactly unchanged, and would sit out the
        next one as well if nothing within the step's reach has changed: it was at rest at
        the step's start, the static friction held it (HELD) or it is a dry film, and its four
        neighbours were at rest too. No mass then crossed its faces (_rest_face), so
        _keep_rest kept its h and h phi bitwise and its momentum stayed 0. Whether the static
        friction holds a cell does not depend on the step length (Physics.holds), so the same
        data around the cell give the same answer in the next step: a cell further than the
        next step's reach from every live cell keeps its bits without being computed. (Rest
        mask of the last step: REST from its start, HELD from its first stage.)"""
        r = ti.cast(self.rest[i, j], ti.i32)
        q = 0
        if (r & REST) != 0:
            if (r & HELD) != 0 or self.q[s, i, j][0] < hmin:
                nb = ti.cast(self.rest[i - 1, j], ti.i32) & ti.cast(self.rest[i + 1, j], ti.i32)
                if ti.static(not self.is_1d):
                    nb &= ti.cast(self.rest[i, j - 1], ti.i32)
                    nb &= ti.cast(self.rest[i, j + 1], ti.i32)
                if (nb & REST) != 0:
                    q = 1
        return q

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
            from ..errors import TisegError

            raise TisegError(
                "numerics.stepper 'hancock' advances by sweeps (tiseg.numerics.split) and "
                "has no semi-discrete operator L to evaluate"
            )

    def rhs(self, src: int, dst: int, t: float) -> None:
        """slot dst := L(slot src, t) on interior cells (fills src's ghost cells)."""
        self._no_operator()
        self._prepare(src, t)
        self._written(dst)
        self._rates(dst, self.serial_loops())

    @staticmethod
    def _terms(terms):
        n = len(terms)
        assert 1 <= n <= MAX_TERMS
        cs = [float(c) for c, _ in terms] + [0.0] * (MAX_TERMS - n)
        ss = [max(int(s), 0) for _, s in terms] + [0] * (MAX_TERMS - n)
        return n, cs, ss

    def combine(self, dst: int, terms, limit: bool = False, tau: float = 0.0, rates=()) -> None:
        """slot dst := sum(c * slot) over terms [(c, slot), ...] on the interior cells a step
        can touch (the active range and its stencil halo; all cells without an active range);
        ``limit=True`` applies the stage limiter (:meth:`_limit`) in the same pass, and with
        the projected friction scheme the friction projection over ``tau`` seconds (the
        stage's share of the step). ``rates``: the slots among the terms that hold rates, not
        states (for the exact rest of _keep_rest).

        dst may be one of the sources: the update is element-wise.
        """
        n, cs, ss = self._terms(terms)
        rmask = self._rate_mask(terms, rates)
        first = self._first_of_step(limit)
        self._combine(
            dst, n, -1, bool(limit), *cs, *ss, float(tau), rmask, first, self.serial_loops()
        )
        self._written(dst, primitives=bool(limit))

    def _first_of_step(self, limit: bool) -> bool:
        """Whether this limited combination is the step's first stage, where a law with
        hysteresis decides which resting cells the static friction holds (_project): the
        first one after the rest mask was computed for a new step."""
        first = bool(limit) and self._first_stage and self.phys.law.hysteresis
        if limit:
            self._first_stage = False
        return first

    def stage(
        self, dst: int, terms, src: int, t: float, limit: bool = True, tau=None, rates=()
    ) -> None:
        """slot dst := sum(c * term) where a term's slot is a slot, or RATE (negative) for
        L(slot src, t): :meth:`rhs` into a spare slot and then :meth:`combine`, with the same
        bits, in one launch and without storing the rate. Exactly one term is the rate.
        ``tau`` (the friction projection's time) defaults to the rate's coefficient: an SSP
        stage is a convex combination of states and one Euler step of that length."""
        self._no_operator()
        rate = [k for k, (_, s) in enumerate(terms) if s < 0]
        assert len(rate) == 1, terms
        tau = terms[rate[0]][0] if tau is None else tau
        self._prepare(src, t)
        n, cs, ss = self._terms(terms)
        rmask = self._rate_mask(terms, rates)
        first = self._first_of_step(limit)
        self._combine(
            dst, n, rate[0], bool(limit), *cs, *ss, float(tau), rmask, first, self.serial_loops()
        )
        self._written(dst, primitives=bool(limit))

    @staticmethod
    def _rate_mask(terms, rates) -> int:
        return sum(1 << k for k, (_, s) in enumerate(terms) if s >= 0 and s in rates)

    def blend(self, dst: int, a: int, b: int, theta: float) -> None:
        """slot dst := (1 - theta) slot a + theta slot b, whole (ghost cells, budget); with
        theta = 0 a copy of slot a. For snapshots between two step states (tiseg.callbacks)."""
        self._written(dst)
        self._blend(dst, a, b, float(theta), self.serial_loops(whole=True))

    def budget(self, slot: int = 0) -> np.ndarray:
        """Accumulated [mass, small mass] that entered through x faces and y faces [m^3]."""
        return self.bud.to_numpy()[slot].astype(float)

    def reset_budget(self, values=None) -> None:
        b = self.bud.to_numpy()
        b[0] = 0.0 if values is None else values
        self.bud.from_numpy(b)

    def sums(self, slot: int = 0) -> tuple[float, float]:
        """(sum of h, sum of h phi) over interior cells, deterministic, in f64."""
        t = self._totals(slot, self.serial_loops(whole=True))
        return float(t[0]), float(t[1])

    def set_active(self, a: int, b: int, wet: tuple[int, int] | None = None) -> None:
        """Restrict the operator to interior x indices [a, b) (array indices, ghosts counted).
        ``wet``: the range [wa, wb) the next wet scan covers (_wet_extent), which holds [a, b);
        by default [a, b) itself. It is wider where resting regions are left out."""
        a = max(self.gx, int(a))
        b = max(a, min(self.gx + self.nx, int(b)))
        wa, wb = (a, b) if wet is None else wet
        wa = min(max(self.gx, int(wa)), a)
        wb = max(min(self.gx + self.nx, int(wb)), b)
        if getattr(self, "wet_range", None) != (wa, wb):
            self.wrng[0] = wa
            self.wrng[1] = wb
            self.wet_range = (wa, wb)
        if getattr(self, "active", None) == (a, b):
            return  # each field write from Python is a kernel launch
        self._prepared = self._interior = None
        if getattr(self, "rest", None) is not None and self._first_stage:
            # the step's rest mask was taken on the old range (_mark_rest: act +- 4) and the
            # step has not begun: take it again on the new one (slot 0 is the same), or
            # cells the range now takes in would keep bits of an earlier step, or none
            self._rest_stale = True
        self.act[0] = a
        self.act[1] = b
        self.active = (a, b)
        # the cells a launch on this range covers: the range and the 3-cell halo of the stencil
        self._serial_active = self._serial_for(min(b - a + 6, self.NX) * self.NY)

    def _serial_for(self, cells: int) -> bool:
        """Loops over ``cells`` cells on one thread? On a CPU with one thread, or at most
        SERIAL_CELLS cells; never on a GPU; ``force_serial`` overrides."""
        if self.force_serial is not None:
            return self.force_serial
        if not self._on_cpu:
            return False
        return self._threads == 1 or cells <= SERIAL_CELLS

    def serial_loops(self, whole: bool = False) -> bool:
        """Whether the next launch runs its loops on one thread: a launch on the active range,
        or on the whole grid (``whole``). Both modes give the same bits
        (tests/test_determinism.py)."""
        return self._serial_whole if whole else self._serial_active

    def wet_extent(self, slot: int, t: float) -> tuple[int, int, int, int]:
        """(first, last) x index with a cell h >= h_min after filling ghosts, (NX, -1) if
        none; then (first, last) x index of a live cell, one that may change in the next step
        (_quiescent), found only where resting regions are skipped (else (NX, -1))."""
        self._set_time(t)
        if self.skip_rest and self._mask_inflow != self.inflow_on(t):
            # the inflow stopped since the last step began: the inlet is a wall now, and the
            # rest mask, taken with the inflow's ghost cells, says nothing of it
            self._forget_rest()
        w = self._wet_extent(slot, self.serial_loops())
        return int(w[0]), int(w[1]), int(w[2]), int(w[3])

    def inflow_on(self, t: float) -> bool:
        """Whether an inflow runs at time t (until the scene's inflow stop time)."""
        return self.bc[0] == "inflow" and not t > self.cfg.inflow_stop

    def _forget_rest(self) -> None:
        """Clear the rest mask: every cell counts as live until a step has marked it again."""
        if getattr(self, "rest", None) is not None:
            self.rest.fill(0)
        # whether an inflow ran when the mask was taken (None: no mask)
        self._mask_inflow = None

    def rest_state(self) -> dict[str, np.ndarray] | None:
        """What the skipping of resting regions needs besides slot 0, for a checkpoint: the
        rest mask of the last step and the active and wet ranges (None without skipping)."""
        if not self.skip_rest:
            return None
        on = -1 if self._mask_inflow is None else int(self._mask_inflow)
        return {
            "rest_mask": self.rest.to_numpy(),
            "ranges": np.array([*self.active, *self.wet_range, on], dtype=np.int64),
        }

    def restore_rest_state(self, rest_mask: np.ndarray, ranges: np.ndarray) -> None:
        """Inverse of :meth:`rest_state` (after slot 0 was set): the next step then skips
        what the run it continues would have skipped, so a resumed run keeps its bits."""
        if not self.skip_rest:
            return
        self.rest.from_numpy(np.asarray(rest_mask).astype(np.int8))
        a, b, wa, wb, on = (int(v) for v in ranges)
        self.set_active(a, b, (wa, wb))
        self._mask_inflow = None if on < 0 else bool(on)

    def stability(self, slot: int, t: float) -> StabilityNumbers:
        self._prepare(slot, t)
        r = [float(v) for v in self._stability(self.serial_loops())]
        return StabilityNumbers(
            ax=r[0],
            ay=r[1],
            rho_visc=r[2],
            rho_fric=r[3],
            max_speed=r[4],
            rho_stiff=r[5],
            rate_local=r[6] if self.local_rate else None,
        )
