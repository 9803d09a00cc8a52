"""Step-size reductions of the operator: the stability pass and the conservation totals.

A collaborator of `tiseg.solver.numerics.operator.TaichiOperator` that receives the operator's
state (`state.OperatorState`): it reads the primitives ``w``, the states ``q``, the parameters,
the active range and the pointwise physics, and writes only its own scratch fields, which the
state allocates with the others (the reduced numbers ``red``, the per-cell speeds ``spd`` of
step_rule "local", the row sums of the totals).

* `StepReductions.stability`: max wave speeds and stiffness bounds of the prepared state
  (`StabilityNumbers`), from which the time steppers and
  `tiseg.run.simulation.step_limits` take the step and the RKC stage count;
* `StepReductions.totals`: sums of h and h phi in a fixed order (the same bits for any
  thread count).
"""

from dataclasses import dataclass

import numpy as np
import taichi as ti

from ...errors import TisegError

from ...taichi_classes import data_oriented

from ...model.physics.params import Params
from .ranges import piece_at, piece_count


@dataclass
class StabilityNumbers:
    ax: float  # max |u| + c (or segregation speed) in x [m/s]
    ay: float
    rho_visc: float  # Gershgorin bound of the viscous Jacobian [1/s]
    rho_fric: float  # friction stiffness, with that of stiff source terms [1/s]
    max_speed: float  # max |u| [m/s]
    rho_stiff: float  # Gershgorin bound of viscous + friction together: max over cells of the
    # sum, <= rho_visc + rho_fric (they peak in different cells) [1/s]
    # step_rule "local" (2D): max over cells of a_x/dx + a_y/dy, each speed the largest of the
    # cell and its two neighbours along that direction [1/s]; None where not computed
    rate_local: float | None = None


NSTAB = 7  # numbers the stability pass reduces (red): the fields above, in order


@data_oriented
class StepReductions:
    def __init__(self, state, fv=None):
        """``state``: the operator's fields, slots and ranges (`state.OperatorState`), which
        also holds this collaborator's fields (``spd``, ``red``, ``rowsum``, ``total``);
        ``fv``: the evaluation of L (`finite_volume.FiniteVolume`), whose preparation of the
        slot the stability pass does in its own launch (None: sums only, no stability)."""
        self.state = state
        self.fv = fv
        fp = state.fp
        self._stability = self._stability_f64 if fp == ti.f64 else self._stability_f32

    def stability(self, slot: int, t: float) -> StabilityNumbers:
        """The numbers of ``slot`` at time t, prepared (`FiniteVolume.preparation`) in the
        same launch."""
        if self.fv is None:
            raise TisegError("StepReductions built without FiniteVolume has no stability pass")
        work = self.fv.preparation(slot, t)
        r = [float(v) for v in self._stability(slot, work[1], work[2], self.state.serial_loops())]
        self.fv.prepared(work, t)
        return self._numbers(r)

    def members(self) -> list[StabilityNumbers]:
        """Each member's numbers of the last stability pass (its row of ``red``)."""
        return [self._numbers([float(v) for v in row]) for row in self.state.red.to_numpy()]

    def _numbers(self, r) -> StabilityNumbers:
        return StabilityNumbers(
            ax=r[0],
            ay=r[1],
            rho_visc=r[2],
            rho_fric=r[3],
            max_speed=r[4],
            rho_stiff=r[5],
            rate_local=r[6] if self.state.local_rate else None,
        )

    def totals(self, slot: int, serial: bool, member: int = 0) -> tuple[float, float]:
        """(sum of h, sum of h phi) over interior cells of ``slot`` of member ``member``,
        deterministic, in f64."""
        t = self._totals(slot, self.state._member(member), serial)
        return float(t[0]), float(t[1])

    def member_totals(self, slot: int, serial: bool) -> np.ndarray:
        """`totals` of every member at once, (M, 2): the same sums in the same order, one
        launch for a batch's members."""
        self._totals_all(slot, serial)
        return self.state.total.to_numpy()

    # The return type must follow the run's precision. A type built from ``float`` is fixed
    # when this module is imported, i.e. before tiseg.init chooses the precision (Taichi's
    # default is f32), which rounded every f64 run's step limits to f32. One kernel per
    # precision, chosen in __init__; only the chosen one is ever compiled (Metal has no f64).
    @ti.kernel
    def _stability_f64(
        self, s: ti.i32, kind: ti.template(), rest: ti.template(), serial: ti.template()
    ) -> ti.types.vector(NSTAB, ti.f64):
        self.fv.prepare_in(s, kind, rest, serial)
        return self._stability_body(serial)

    @ti.kernel
    def _stability_f32(
        self, s: ti.i32, kind: ti.template(), rest: ti.template(), serial: ti.template()
    ) -> ti.types.vector(NSTAB, ti.f32):
        self.fv.prepare_in(s, kind, rest, serial)
        return self._stability_body(serial)

    @ti.func
    def _stability_body(self, serial: ti.template()):
        """Max wave speeds, Gershgorin bound of the viscous Jacobian and friction stiffness
        from the primitives of the current state. Pieces of blocks of rows run in parallel
        and reduce locally, so there is at most one atomic per piece (maxima are order
        independent: deterministic); a block is one row in 2D, cut into ``row_pieces``
        pieces along y (tiseg.solver.numerics.ranges.row_pieces), and 256 cells of the row
        in 1D, where an atomic per cell would serialise the threads on one address.

        The friction Jacobian is local to a cell (a 2 x 2 block in (hu, hv) bounded by the
        friction rate), so it adds to the diagonal of that cell's viscous rows: Gershgorin's
        theorem bounds the spectrum of both terms together by the largest per-cell sum
        (red[5]). The friction peaks in slow thin margins and levees, the viscosity in thick
        fast channels, so the sum of the two maxima (red[2] + red[3]) overestimates it by up
        to 2x, and the RKC stage count with it.

        With step_rule "local" (2D) red[6] is the largest per-cell convective rate
        max(a_x over i-1..i+1)/dx + max(a_y over j-1..j+1)/dy: the speeds of the faces of the
        cell, which bound the forward-Euler step that keeps that cell's h >= 0 (see
        tiseg.run.simulation.step_limits). Only such runs compute it."""
        gx, nx, gy, ny = ti.static(self.state.gx, self.state.nx, self.state.gy, self.state.ny)
        ti.loop_config(serialize=True)  # a handful of iterations
        for k, e in ti.ndrange(NSTAB, self.state.M):
            self.state.red[e, k] = 0.0
        # include the first ghost layer in x so that an inflow into an empty chute sets a speed
        lo = ti.max(self.state.act[0] - 1, gx - 1)
        hi = ti.min(self.state.act[1] + 1, gx + nx + 1)
        B = ti.static(self.state.rows_per_block)
        if ti.static(self.state.local_rate):
            # each cell's (a_x, a_y) once, neighbours and ghost rows included: the rate reads
            # 5 speeds per cell, and recomputing them (a square root each) cost 10 % of a
            # Stoker step on one thread
            ti.loop_config(serialize=serial)
            for i, j, e in ti.ndrange((lo - 1, hi + 1), (0, self.state.NY), self.state.M):
                w = self.state.w[i, j, e]
                g = self.state.grav.cell(e, i)
                self.state.spd[i, j, e] = ti.Vector(
                    [self.state.phys.speed(e, w, 0, g), self.state.phys.speed(e, w, 1, g)]
                )
        P = ti.static(self.state.row_pieces)
        ti.loop_config(serialize=serial)
        for it, e in ti.ndrange(piece_count(lo, hi, B, P), self.state.M):
            hmin = self.state.par[e, Params.H_MIN]
            idx = self.state.par[e, Params.INV_DX]
            idy = self.state.par[e, Params.INV_DY]
            i0, j0, j1 = piece_at(it, lo, B, P, gy, ny)
            m0 = 0.0
            m1 = 0.0
            m2 = 0.0
            m3 = 0.0
            m4 = 0.0
            m5 = 0.0
            m6 = 0.0
            for r in range(B):
                i = i0 + r
                if i < hi:
                    for j in range(j0, j1):
                        w = self.state.w[i, j, e]
                        g = self.state.grav.cell(e, i)
                        if ti.static(self.state.local_rate):
                            sp = self.state.spd[i, j, e]
                            m0 = ti.max(m0, sp[0])
                            m1 = ti.max(m1, sp[1])
                            axm = ti.max(
                                ti.max(self.state.spd[i - 1, j, e][0], sp[0]),
                                self.state.spd[i + 1, j, e][0],
                            )
                            aym = ti.max(
                                ti.max(self.state.spd[i, j - 1, e][1], sp[1]),
                                self.state.spd[i, j + 1, e][1],
                            )
                            m6 = ti.max(m6, axm * idx + aym * idy)
                        else:
                            m0 = ti.max(m0, self.state.phys.speed(e, w, 0, g))
                            if ti.static(not self.state.is_1d):
                                m1 = ti.max(m1, self.state.phys.speed(e, w, 1, g))
                        m4 = ti.max(m4, self.state.phys.speed_mag(w))
                        fr = self.state.phys.friction_rate(e, w, g)
                        if ti.static(self.state.terms.stiff_on):  # stiff source terms
                            fr += self.state.terms.stiffness(e, i, j)
                        m3 = ti.max(m3, fr)
                        rho = 0.0 * fr
                        if ti.static(self.state.visc):
                            h = w[0]
                            if h >= hmin and gx <= i < gx + nx:
                                hn = h  # (not read in 1D)
                                hs = h
                                if ti.static(not self.state.is_1d):
                                    hn = self.state.w[i, j + 1, e][0]
                                    hs = self.state.w[i, j - 1, e][0]
                                rho = self.state.phys.visc_stiffness(
                                    e,
                                    h,
                                    self.state.w[i + 1, j, e][0],
                                    self.state.w[i - 1, j, e][0],
                                    hn,
                                    hs,
                                    idx,
                                    idy,
                                )
                                m2 = ti.max(m2, rho)
                        m5 = ti.max(m5, rho + fr)
            # an atomic only where it raises the maximum: a stale read can only be lower (the
            # maxima only grow), so the atomic is never skipped where it is needed, and the
            # threads no longer take turns on one cache line for every piece
            for k, m in ti.static(enumerate((m0, m1, m2, m3, m4, m5, m6))):
                if m > self.state.red[e, k]:
                    ti.atomic_max(self.state.red[e, k], m)
        # member 0's numbers, returned (a single run reads no field); every member's are in red
        return ti.Vector([self.state.red[0, k] for k in ti.static(range(NSTAB))])

    @ti.kernel
    def _totals_all(self, s: ti.i32, serial: ti.template()):
        """`_totals` of every member into total (M, 2), each member's rows and then its
        sum in the order `_totals` takes them: the same bits."""
        gx, nx = ti.static(self.state.gx, self.state.nx)
        ti.loop_config(serialize=serial)
        for i, e in ti.ndrange((gx, gx + nx), self.state.M):
            self._row_sums(s, i, e)
        ti.loop_config(serialize=True)
        for e in range(self.state.M):
            self.state.total[e, 0] = 0.0
            self.state.total[e, 1] = 0.0
            for i in range(gx, gx + nx):
                self.state.total[e, 0] += self.state.rowsum[e, i, 0]
                self.state.total[e, 1] += self.state.rowsum[e, i, 1]

    @ti.kernel
    def _totals(self, s: ti.i32, e: ti.i32, serial: ti.template()) -> ti.types.vector(2, ti.f64):
        """Sums of h and h phi over member e's interior cells in a fixed order (rows in
        parallel, each summed serially, then the rows serially): the same bits for any thread
        count."""
        gx, nx = ti.static(self.state.gx, self.state.nx)
        self.state.total[e, 0] = 0.0
        self.state.total[e, 1] = 0.0
        ti.loop_config(serialize=serial)
        for i in range(gx, gx + nx):
            self._row_sums(s, i, e)
        ti.loop_config(serialize=True)
        for i in range(gx, gx + nx):
            self.state.total[e, 0] += self.state.rowsum[e, i, 0]
            self.state.total[e, 1] += self.state.rowsum[e, i, 1]
        return ti.Vector([self.state.total[e, 0], self.state.total[e, 1]])

    @ti.func
    def _row_sums(self, s, i, e):
        """Row i of slot s of member e: the sums of h and h phi along y, taken serially (a
        fixed order), into rowsum."""
        gy, ny = ti.static(self.state.gy, self.state.ny)
        a = ti.cast(0.0, ti.f64)
        b = ti.cast(0.0, ti.f64)
        for j in range(gy, gy + ny):
            v = self.state.q[s, i, j, e]
            a += ti.cast(v[0], ti.f64)
            if ti.static(self.state.seg):
                b += ti.cast(v[self.state.HPHI], ti.f64)
        self.state.rowsum[e, i, 0] = a
        self.state.rowsum[e, i, 1] = b
