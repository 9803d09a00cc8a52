"""The viscous sub-step V of a split step (``numerics.stepper = "hancock"`` with viscosity).

With viscosity a split step of dt is the symmetric pair of half steps x(dt/2) y(dt/2) | V(dt) |
y(dt/2) x(dt/2) (x | V | x in 1D; tiseg.solver.numerics.split gives the reasons). V moves only
the momenta: the divergence of the unsplit operator's viscous face stresses
(`finite_volume.FiniteVolume.x_viscous`, ``y_viscous``), integrated by the RKC stages the
stepper plans (tiseg.solver.timestepping.split), summed as increments so that a cell whose
viscous rates are zero at every stage keeps its bits. Through a running inlet V takes no
stress (`ViscousSubstep._inlet_velocities`).

A collaborator of `tiseg.solver.numerics.operator.TaichiOperator` that receives the operator's
state (`state.OperatorState`), its ghost cells and its finite-volume evaluation. Its NumPy twin
is `tiseg.solver.reference.split.viscous_substep`.
"""

import numpy as np
import taichi as ti

from ...taichi_classes import data_oriented

from ...errors import TisegError
from ...model.physics.params import Params
from .boundaries import inlet_rows
from .state import C_DST, C_FINAL, C_LIVE


@data_oriented
class ViscousSubstep:
    """The stages of the viscous sub-step of a split step."""

    def __init__(self, state, ghosts, fv):
        """``state``: the operator's fields, slots and ranges (`state.OperatorState`);
        ``ghosts``: its ghost cells (`ghosts.GhostCells`); ``fv``: the evaluation of L whose
        viscous stresses, primitives and limiter V uses (`finite_volume.FiniteVolume`)."""
        self.state = state
        self.ghosts = ghosts
        self.fv = fv
        self.inlet_rows = (0, 0)  # (set by viscous_stage before its kernel compiles)

    def viscous_stage(
        self,
        src: int,
        prev2: int,
        dst,
        coeffs: tuple,
        t,
        first: bool = False,
        live=None,
    ) -> None:
        """One stage of the viscous sub-step V of a split step (the RKC stages of
        tiseg.solver.timestepping.split.Hancock), in one launch, on the cells a sweep updates:

            slot dst := Y0 + mu (Y_src - Y0) + nu (Y_prev2 - Y0) + ct V(Y_src) + cg F0

        with Y0 = slot 0 (the state V started from), F0 = slot 1 and ``coeffs`` = (mu, nu, ct,
        cg). ``src`` = 0 (with ``prev2`` < 0) is the first stage, which also stores V(Y0) in
        slot 1; ``dst`` = 0 is the last, which writes the result over Y0 (stage limiter; the
        friction is projected by the sweep that closes the half, not here). V is the
        divergence of the viscous stress of (6.2) (FiniteVolume.x_viscous, y_viscous):
        only the momenta change, and a cell whose rates are zero at every stage keeps its bits
        (the increments are summed before Y0 is added). ``t``: the time of Y_src (an inflow's
        ghost cells); ``first``: the stage opens the second half of the split step (the rest
        mask and the speeds of the state V starts from, as a first sweep).

        In a batch ``t``, the coefficients and ``dst`` may be one per member (a member whose
        last stage this is writes slot 0), and ``live`` (one bool per member) leaves out the
        members whose stages are done."""
        fr = self.state.phys.fr_projected
        one = src == 0
        for d in set(np.atleast_1d(dst).tolist()) if self.state.batched else (dst,):
            _check_stage(src, prev2, int(d), bool(fr and first))
        if fr and first:
            self.fv.prepare(0, t)  # the rest mask of the step's initial state (if not taken)
        self.state.set_time(t)
        fresh = self.state.fresh(src, t)
        first = bool(fr and first)
        if self.state.batched:  # each member's numbers, read by the kernel
            cols = dict(enumerate(coeffs))
            cols.update({C_DST: dst, C_FINAL: np.asarray(dst) == 0})
            if live is not None:
                cols[C_LIVE] = np.asarray(live, dtype=float)
            self.state.put_numbers(cols)
            mu = nu = ct = cg = 0.0
            final = 2
        else:
            mu, nu, ct, cg = (float(c) for c in coeffs)
            final = int(dst == 0)
        # the inlet's rows of w (_inlet_velocities; inflow.width and inflow.y0 are compiled
        # in), the ghost rows where it reaches the domain's side: the cross derivatives at
        # the inlet's faces read them
        self.inlet_rows = inlet_rows(self.state.cfg.layout, self.state.cfg.inflow_rows)
        self._viscous(
            src,
            max(prev2, 0),
            0 if self.state.batched else int(dst),
            mu,
            nu,
            ct,
            cg,
            fresh,
            one,
            final,
            first,
            self.state.serial_loops(),
        )
        self.state.written_by(dst, live, True)

    @ti.kernel
    def _viscous(
        self,
        src: ti.i32,
        prev2: ti.i32,
        dst: ti.i32,
        mu: float,
        nu: float,
        ct: float,
        cg: float,
        fresh: ti.template(),
        one: ti.template(),
        final: ti.template(),
        first: ti.template(),
        serial: ti.template(),
    ):
        """A stage of V (viscous_stage): ghosts and primitives of slot src as far as
        ``fresh`` says they are stale, the viscous face stresses, the stage's combination."""
        if ti.static(fresh < 2):
            self.ghosts.fill(src)
            if ti.static(fresh == 1):
                self.fv.edge_primitives(src, serial)
            else:
                self.fv.primitives(src, serial)
        if ti.static(self.state.bcs[0].prescribed):
            self._inlet_velocities()
        self._viscous_faces(serial)
        self._viscous_update(src, prev2, dst, mu, nu, ct, cg, one, final, first, serial)

    @ti.func
    def _inlet_velocities(self):
        """While an inflow runs, its ghost cells' velocities in w are those of the interior
        cells next to them: no viscous stress through the inlet, as a uniform inflow has none
        in the unsplit scheme. The prescribed state is one that the friction balances, and
        the inlet cells V sees are not that state within a step (the sweeps' gravity
        impulse and the projection of the half step act on them): a prescribed ghost
        velocity would drag them toward it at every V (with V after the sweeps, before the
        friction, it left the fingers chute at 250 cells/m 0.35 % thin all the way down)."""
        gx = ti.static(self.state.gx)
        lo, hi = ti.static(self.inlet_rows)
        ti.loop_config(serialize=self.state.strip_serial)  # the inlet's ghost columns
        for k, m, e in ti.ndrange(gx, (lo, hi), self.state.M):
            if self.state.par[e, Params.IN_ON] > 0.5:
                g = self.state.w[gx - 1 - k, m, e]
                g[1] = self.state.w[gx, m, e][1]
                if ti.static(not self.state.is_1d):
                    g[self.state.HV] = self.state.w[gx, m, e][self.state.HV]
                self.state.w[gx - 1 - k, m, e] = g

    @ti.func
    def _viscous_faces(self, serial: ti.template()):
        """The viscous stresses alone through the faces a sweep's update reads: x faces
        (i, i + 1) for i in [a - 1, b) on the interior rows, y faces (j, j + 1) for j in
        [gy - 1, gy + ny) on the columns [a, b), in fx and fy."""
        gy, ny = ti.static(self.state.gy, self.state.ny)
        a, b = self.state.act[0], self.state.act[1]
        if ti.static(self.state.is_1d):
            ti.loop_config(serialize=serial)
            for i, j, e in ti.ndrange((a - 1, b), (gy, gy + ny), self.state.M):
                zero = ti.Vector.zero(self.state.fp, self.state.nc)
                self.state.fx[i, j, e] = self.fv.x_viscous(
                    e, zero, i, j, self.state.w[i, j, e], self.state.w[i + 1, j, e]
                )
        else:
            ti.loop_config(serialize=serial)
            for i, j, e in ti.ndrange((a - 1, b), (gy - 1, gy + ny), self.state.M):
                zero = ti.Vector.zero(self.state.fp, self.state.nc)
                w0 = self.state.w[i, j, e]
                if j >= gy:
                    self.state.fx[i, j, e] = self.fv.x_viscous(
                        e, zero, i, j, w0, self.state.w[i + 1, j, e]
                    )
                if i >= a:
                    self.state.fy[i, j, e] = self.fv.y_viscous(
                        e, zero, i, j, w0, self.state.w[i, j + 1, e]
                    )

    @ti.func
    def _viscous_update(
        self,
        src,
        prev2,
        dst,
        mu,
        nu,
        ct,
        cg,
        one: ti.template(),
        final: ti.template(),
        first: ti.template(),
        serial: ti.template(),
    ):
        """The stage's combination on the interior rows of the x range [a - 3, b + 3) that
        the next stage's primitives read (the rate is zero outside the active range [a, b),
        so there every stage equals Y0), with the primitives of the result into w; the last
        stage writes slot 0 on [a, b) only."""
        gx, nx, gy, ny = ti.static(self.state.gx, self.state.nx, self.state.gy, self.state.ny)
        a, b = self.state.act[0], self.state.act[1]
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange(
            (ti.max(a - 3, gx), ti.min(b + 3, gx + nx)), (gy, gy + ny), self.state.M
        ):
            if self.state.live(e):  # (a batch's member whose stages are done is left out)
                mu_e = self.state.number(e, 0, mu)
                nu_e = self.state.number(e, 1, nu)
                ct_e = self.state.number(e, 2, ct)
                cg_e = self.state.number(e, 3, cg)
                idx = self.state.par[e, Params.INV_DX]
                idy = self.state.par[e, Params.INV_DY]
                y0 = self.state.q[0, i, j, e]
                r = ti.Vector.zero(self.state.fp, self.state.nc)
                inside = a <= i < b
                if inside:
                    r = -(self.state.fx[i, j, e] - self.state.fx[i - 1, j, e]) * idx
                    if ti.static(not self.state.is_1d):
                        r -= (self.state.fy[i, j, e] - self.state.fy[i, j - 1, e]) * idy
                acc = y0
                if ti.static(one):
                    self.state.q[1, i, j, e] = r  # F0
                    acc = y0 + ct_e * r
                    if ti.static(first):
                        self.state.spd0[i, j, e] = self.state.phys.speed_mag(
                            self.state.w[i, j, e]
                        )  # (the step's start)
                else:
                    inc = mu_e * (self.state.q[src, i, j, e] - y0) + nu_e * (
                        self.state.q[prev2, i, j, e] - y0
                    )
                    acc = y0 + (inc + ct_e * r + cg_e * self.state.q[1, i, j, e])
                if ti.static(final == 2):  # a batch: the member's own last stage or not
                    if self.state.coef[e, C_FINAL] > 0.5:
                        acc = self._last(e, i, j, acc, y0, inside)
                    else:
                        self.state.q[self.state.dst(e, dst), i, j, e] = acc
                elif ti.static(final == 1):
                    acc = self._last(e, i, j, acc, y0, inside)
                else:
                    self.state.q[dst, i, j, e] = acc
                self.state.w[i, j, e] = self.fv.fast_primitive(e, acc)

    @ti.func
    def _last(self, e, i, j, acc, y0, inside):
        """The last stage's result at cell (i, j) of member e: limited and written over Y0
        on the active range, Y0 itself beside it."""
        out = y0
        if inside:
            out = self.fv.limit(e, acc)
            self.state.q[0, i, j, e] = out
        return out


def _check_stage(src: int, prev2: int, dst: int, opens: bool) -> None:
    """The slots of a viscous stage as `ViscousSubstep.viscous_stage` takes them: the first
    stage (src 0) alone has no second-last slot and never writes over Y0; a stage that opens
    a half step is a first one."""
    one = src == 0
    if one != (prev2 < 0) or (dst == 0 and one) or (opens and not one):
        raise TisegError(f"viscous_stage: slots src={src}, prev2={prev2}, dst={dst} do not fit")
