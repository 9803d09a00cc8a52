"""Slot algebra of the operator: linear combinations of its state slots, with the stage
limiter, fused stages and the boundary budgets that follow the states.

States live in one field ``q`` of ``nslots`` slots (Taichi compiles one kernel per distinct field
passed as template, so buffers are slots selected by an integer). The time steppers
(`tiseg.solver.timestepping`) build their stages from `SlotAlgebra.combine` (slot dst := sum of
c * slot), `SlotAlgebra.stage` (the same with one term the rate L of a slot, computed in
the same launch) and `SlotAlgebra.blend` (snapshots between two step states). Each
applies the same combination to the boundary budgets (``bud``), so slot 0 accumulates exactly
the time integral of the inflow the scheme uses.

A collaborator of `tiseg.solver.numerics.operator.TaichiOperator`: it receives the operator's
state (`state.OperatorState`, whose slots, budgets and caches it writes), the evaluation of L
(`finite_volume.FiniteVolume`: a fused stage's rate, the stage limiter) and the rest rules
(`rest.RestRules`: the friction projection of a limited stage and its exact rest).
"""

import numpy as np
import taichi as ti

from ...taichi_classes import data_oriented

from ...errors import TisegError

from .state import C_DST, C_LIVE, C_TAU, NBUDGET

MAX_TERMS = 6


@data_oriented
class SlotAlgebra:
    def __init__(self, state, fv, rules):
        """``state``: the slots and the budgets they carry (`state.OperatorState`); ``fv``:
        the evaluation of L whose rate a fused stage uses and whose limiter a limited stage
        applies (`finite_volume.FiniteVolume`); ``rules``: the friction projection and exact
        rest of a limited stage (`rest.RestRules`)."""
        self.state = state
        self.fv = fv
        self.rules = rules

    def combine(self, dst, terms, limit: bool = False, tau=0.0, rates=(), live=None) -> None:
        """slot dst := sum(c * slot) over terms [(c, slot), ...] on the interior cells a step
        can touch (the active range and its stencil halo; all cells without an active range);
        ``limit=True`` applies the stage limiter (`limit`) in the same pass, and with
        the projected friction scheme the friction projection over ``tau`` seconds (the
        stage's share of the step). ``rates``: the slots among the terms that hold rates, not
        states (for the exact rest of keep_rest).

        In a batch the coefficients, ``tau`` and ``dst`` may be one per member, and ``live``
        (one bool per member) leaves out the members this combination is not a stage of.

        dst may be one of the sources: the update is element-wise.
        """
        n, cs, ss = self._terms(terms)
        rmask = self._rate_mask(terms, rates)
        first = self.state.first_of_step(limit)
        d, tau = self._numbers(dst, terms, tau, live)
        self._combine(d, n, -1, bool(limit), *cs, *ss, tau, rmask, first, self.state.serial_loops())
        self.state.written_by(dst, live, bool(limit))

    def stage(
        self, dst, terms, src: int, t, limit: bool = True, tau=None, rates=(), live=None
    ) -> None:
        """slot dst := sum(c * term) where a term's slot is a slot, or RATE (negative) for
        L(slot src, t): `rhs` into a spare slot and then `combine`, with the same
        bits, in one launch and without storing the rate. Exactly one term is the rate.
        ``tau`` (the friction projection's time) defaults to the rate's coefficient: an SSP
        stage is a convex combination of states and one Euler step of that length. In a batch
        t, the coefficients, tau and dst may be one per member, and ``live`` as in `combine`."""
        self.fv.no_operator()
        rate = [k for k, (_, s) in enumerate(terms) if s < 0]
        if len(rate) != 1:
            raise TisegError(f"combine_rate: exactly one term must be the rate, got {terms!r}")
        tau = terms[rate[0]][0] if tau is None else tau
        self.fv.prepare(src, t)
        n, cs, ss = self._terms(terms)
        rmask = self._rate_mask(terms, rates)
        first = self.state.first_of_step(limit)
        d, tau = self._numbers(dst, terms, tau, live)
        self._combine(
            d,
            n,
            rate[0],
            bool(limit),
            *cs,
            *ss,
            tau,
            rmask,
            first,
            self.state.serial_loops(),
        )
        self.state.written_by(dst, live, bool(limit))

    def _numbers(self, dst, terms, tau, live) -> tuple[int, float]:
        """A combination's kernel arguments (dst, tau) of a single run; in a batch its
        numbers per member written into the state's coef (the kernel reads them there)."""
        st = self.state
        if not st.batched:
            return int(dst), float(tau)
        cols = {k: c for k, (c, _) in enumerate(terms)}
        cols.update({C_TAU: tau, C_DST: dst})
        if live is not None:
            cols[C_LIVE] = np.asarray(live, dtype=float)
        st.put_numbers(cols)
        return 0, 0.0

    @staticmethod
    def _rate_mask(terms, rates) -> int:
        return sum(1 << k for k, (_, s) in enumerate(terms) if s >= 0 and s in rates)

    @staticmethod
    def _terms(terms):
        n = len(terms)
        if not 1 <= n <= MAX_TERMS:
            raise TisegError(f"a combination takes 1 to {MAX_TERMS} terms, got {n}")
        cs = [float(c) if np.ndim(c) == 0 else 0.0 for c, _ in terms] + [0.0] * (MAX_TERMS - n)
        ss = [max(int(s), 0) for _, s in terms] + [0] * (MAX_TERMS - n)
        return n, cs, ss

    def blend(self, dst: int, a: int, b: int, theta: float, member: int | None = None) -> None:
        """slot dst := (1 - theta) slot a + theta slot b, whole (ghost cells, budget); with
        theta = 0 a copy of slot a. For snapshots between two step states (tiseg.run.callbacks).
        ``member``: of that member of a batch alone (each member's snapshot its own; None:
        every member)."""
        self.state.written(dst)
        serial = self.state.serial_loops(whole=True)
        if member is None or not self.state.batched:
            self._blend(dst, a, b, float(theta), serial)
        else:
            self._blend_one(dst, a, b, float(theta), self.state._member(member), serial)

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
            self.fv.face_fluxes(serial)
            self.fv.boundary_rates(self.state.nslots)
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
        L at the cell (cell_rate); then the stage limiter if ``limit``, which also leaves the
        result's primitives in w (the next evaluation is of slot d). The sum runs in the order
        of the terms, so a fused stage gives the bits of _rates followed by _combine.

        Cells: the active x range widened by the 3 cells either side that the next
        evaluation's stencil reads. Why that is enough: the active range is fixed for the
        whole step (set_active runs between steps), every rate is zero on the widened range
        outside the active one (cell_rate), and the first stage combines from slot 0, which
        is valid everywhere. So within a step every slot is valid on the widened range, and
        nothing beyond it is read. Cells further out are dry films that the step does not
        change; skipping them saves two passes over the dry chute per stage.

        A cell's rate reads the face fluxes and its own primitives only, so d may be the slot
        the rate is of, or any of the sources: the update is element-wise.

        With the projected friction scheme the limiter is followed by the friction projection
        over ``tau``, the stage's share of the step (project), and by keep_rest; bit k of
        ``rmask`` marks term k as a stored rate rather than a state; ``first``: this is the
        step's first stage (its static-friction decisions are made here)."""
        gx, nx, gy, ny = ti.static(self.state.gx, self.state.nx, self.state.gy, self.state.ny)
        lo = ti.max(self.state.act[0] - 3, gx)
        hi = ti.min(self.state.act[1] + 3, gx + nx)
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange((lo, hi), (gy, gy + ny), self.state.M):
            if self.state.live(e):  # (a batch's member that takes this stage)
                ce = self.state.numbers(e, cs)
                te = self.state.number(e, C_TAU, tau)
                r = ti.Vector.zero(self.state.fp, self.state.nc)
                # the speed of the state the stage starts from (the prepared one): the friction
                # coefficient of the projection (Physics.project_friction)
                spd0 = 0.0 * r[0]
                if ti.static(limit and self.state.phys.fr_projected):
                    spd0 = self.state.phys.speed_mag(self.state.w[i, j, e])
                if ti.static(rate >= 0):
                    r = self.fv.cell_rate(e, i, j)
                acc = ti.Vector.zero(self.state.fp, self.state.nc)
                for k in ti.static(range(n)):
                    term = r if ti.static(k == rate) else self.state.q[ss[k], i, j, e]
                    if ti.static(k == 0):
                        acc = ce[0] * term
                    else:
                        acc += ce[k] * term
                if ti.static(limit):
                    acc = self.fv.limit(e, acc)
                    if ti.static(self.state.phys.fr_projected):
                        acc = self.rules.project(e, acc, te, i, j, first, spd0, acc[0])
                        acc = self.rules.keep_rest(e, acc, r, i, j, n, rate, rmask, ss)
                    self.state.w[i, j, e] = self.fv.primitive(e, acc)
                self.state.q[self.state.dst(e, d), i, j, e] = acc
        ti.loop_config(serialize=True)  # a handful of iterations
        for b, e in ti.ndrange(NBUDGET, self.state.M):
            if self.state.live(e):
                ce = self.state.numbers(e, cs)
                acc = 0.0 * ce[0]
                for k in ti.static(range(n)):
                    bk = (
                        self.state.bud[e, self.state.nslots, b]
                        if ti.static(k == rate)
                        else self.state.bud[e, ss[k], b]
                    )
                    if ti.static(k == 0):
                        acc = ce[0] * bk
                    else:
                        acc += ce[k] * bk
                self.state.bud[e, self.state.dst(e, d), b] = acc

    @ti.kernel
    def _blend(self, d: ti.i32, a: ti.i32, b: ti.i32, theta: float, serial: ti.template()):
        """slot d := (1 - theta) slot a + theta slot b on every cell, ghosts included, and the
        same for the budgets (no active range: a copy must be whole). Written a + theta (b - a),
        which gives a's bits where b == a: a deposit at rest then has the same h in every
        snapshot, as it has in the step states ((1 - theta) a + theta a can be an ulp off)."""
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange(self.state.NX, self.state.NY, self.state.M):
            qa = self.state.q[a, i, j, e]
            self.state.q[d, i, j, e] = qa + theta * (self.state.q[b, i, j, e] - qa)
        ti.loop_config(serialize=True)  # a handful of iterations
        for k, e in ti.ndrange(NBUDGET, self.state.M):
            self.state.bud[e, d, k] = self.state.bud[e, a, k] + theta * (
                self.state.bud[e, b, k] - self.state.bud[e, a, k]
            )

    @ti.kernel
    def _blend_one(
        self, d: ti.i32, a: ti.i32, b: ti.i32, theta: float, e: ti.i32, serial: ti.template()
    ):
        """`_blend` of member e of a batch alone."""
        ti.loop_config(serialize=serial)
        for i, j in ti.ndrange(self.state.NX, self.state.NY):
            qa = self.state.q[a, i, j, e]
            self.state.q[d, i, j, e] = qa + theta * (self.state.q[b, i, j, e] - qa)
        ti.loop_config(serialize=True)  # a handful of iterations
        for k in range(NBUDGET):
            self.state.bud[e, d, k] = self.state.bud[e, a, k] + theta * (
                self.state.bud[e, b, k] - self.state.bud[e, a, k]
            )
