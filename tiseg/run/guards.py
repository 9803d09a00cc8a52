"""Guards: stop a run as soon as its state leaves what the model allows, and say where.

The state of a run (slot 0 of the `tiseg.solver.numerics.operator.TaichiOperator`) must hold
finite numbers, a thickness h >= 0 and, where the chute is wet (h >= h_min), a concentration
0 <= phi = (h phi) / h <= 1. `StateGuard` checks all of this in one Taichi reduction over
the interior cells:

* every violated rule counts its cells with integer atomics and keeps its *first* offending cell
  (smallest linear index) with ``atomic_min``, so the report is the same for any thread count;
* only a (4, 2) integer table comes back to the host: a check costs one kernel launch and a tiny
  copy, about as much as one of the ~15 kernels of an RKC step (measured in
  ``tests/test_hard_cases.py``, see `measure_overhead`), so it can run every few steps;
* after a check that passes, the state (ghost cells included) and the boundary budget are copied,
  on the device, into a "last good" buffer, so that a failure can save the last state that passed
  next to the offending one;
* in a batch (`tiseg.run.batch`) the members due a check after a step are scanned by one launch
  and the last good states of those that passed are copied by one (`GuardStore.scan_members`,
  `GuardStore.flush`).

Tolerances (why not exactly zero): the operator's ``postprocess`` clamps h >= 0 and
0 <= h phi <= h after every stage, so in slot 0 h < 0 and phi outside [0, 1] cannot occur from the
scheme itself; the guard still checks them with a round-off tolerance (a few ulps of the
reference thickness for h, a few ulps relative for phi, where phi = h phi / h is a division) so
that a future stepper or a state set by hand is caught too, while round-off is not.

A NaN is the failure that matters in practice. The operator's stage limiter clamps h >= 0 with a
select that lets a NaN through (``max(NaN, 0)`` would give 0 and hide it as an empty cell), so a
NaN made inside a step reaches slot 0 and the scan names its cell. The guard also checks the
mass balance (total mass against the initial mass plus what entered through the boundaries)
with a loose tolerance, see `StateGuard.mass_tol`: mass lost by any other route shows there.
"""
# (no "from __future__ import annotations": Taichi reads kernel annotations as objects)

import math
from dataclasses import dataclass

import numpy as np
import taichi as ti

from ..taichi_classes import data_oriented

from ..solver.field_tree import FieldTree
from ..solver.numerics.operator import NBUDGET

# Rules, in the order of the result table; a cell is reported under the first rule it breaks.
NONFINITE, NEG_H, PHI_LOW, PHI_HIGH = range(4)
RULES = ("non-finite value", "negative thickness", "concentration below 0", "concentration above 1")
_NO_CELL = 2**31 - 1


@dataclass
class Violation:
    """One broken rule: what, where (cell indices and metres) and how many cells."""

    rule: str  # one of RULES, or "mass balance"
    field: str  # "h", "hu", "hv", "h*phi", "phi" or "mass"
    i: int  # interior cell index along x (0 .. nx-1); -1 for the mass balance
    j: int  # interior cell index along y (0 .. ny-1)
    x: float  # cell centre [m]
    y: float
    value: float  # the offending value (phi for phi rules, h for h, the component else)
    count: int  # cells breaking this rule
    t: float  # simulated time [s]
    step: int  # steps taken when it was found

    def message(self) -> str:
        if self.rule == "mass balance":
            what = (
                f"differs from initial + boundary inflow by a relative {self.value:.3g}"
                if math.isfinite(self.value)
                else "is not finite (NaN in the total or in the boundary budget)"
            )
            return (
                f"mass balance broken at t={self.t:.9g} s (step {self.step}): the {self.field} "
                f"{what}"
            )
        more = f" (and {self.count - 1} more cells)" if self.count > 1 else ""
        return (
            f"{self.rule} {self.field}={self.value!r} at t={self.t:.9g} s (step {self.step}) "
            f"in cell (i={self.i}, j={self.j}) at x={self.x:.6g} m, y={self.y:.6g} m{more}"
        )


@data_oriented
class GuardStore:
    """The guard's fields for every member of an operator's state, on the device: the
    result table (members, 4, 2), each member's tolerances and h_min, and the last good
    state and budget. One per state (`OperatorState.observer`), which each member's
    `StateGuard` uses with its own index, so a batch traces and compiles these kernels
    once."""

    def __init__(self, state):
        self.op = state
        M = state.M
        ft = self.field_tree = FieldTree()  # freed with this object
        self.res = ft.field(ti.i32, (M, 4, 2))
        self.par = ft.field(state.fp, (M, 3))  # h_tol, phi_tol, h_min
        self.good = ft.vector(state.nc, state.fp, (state.NX, state.NY, M))
        self.good_bud = ft.field(state.fp, (M, NBUDGET))
        ft.finalize()
        ft.free_with(self)
        self.par_host = np.zeros((M, 3), dtype=state.np_fp)
        # a batch's store (`tiseg.run.batch.Batch` sets ``shared``): the members due a check
        # after a step are scanned in one launch (`scan_members`), and the states of those
        # that passed are kept by one launch after the step (`flush`)
        self.shared = False
        self._table = None  # the result tables of the last shared scan, (M, 4, 2)
        self._scanned = None  # the members it holds
        self._changes = None  # the state's change count when it was taken
        self._pending = np.zeros(M, dtype=np.int32)  # members whose keep is not yet copied

    def scan_members(self, on) -> None:
        """Scan slot 0 of every member e with on[e] in one launch; each member's `table`
        reads its rows until the state changes."""
        on = np.ascontiguousarray(on, dtype=np.int32)
        self._scan_members(on, self.op.serial_loops(whole=True))
        self._table, self._scanned = self.res.to_numpy(), on != 0
        self._changes = self.op.changes

    def table(self, e: int) -> np.ndarray:
        """Member e's result table (4, 2) of its slot 0 now: the shared scan's where it holds
        the member and the state has not changed since, else one launch of its own."""
        if self._table is not None and self._scanned[e] and self._changes == self.op.changes:
            return self._table[e]
        self._scan(e, self.op.serial_loops(whole=True))
        return self.res.to_numpy()[e]

    def keep(self, e: int) -> None:
        """Member e's slot 0 and budget into its last-good buffer: now, or in a shared store
        with the others' at the next `flush`."""
        if self.shared:
            self._pending[e] = 1
        else:
            self._keep(e, self.op.serial_loops(whole=True))

    def flush(self) -> None:
        """Copy the keeps not yet copied, in one launch (before the states change again)."""
        if self._pending.any():
            self._keep_members(self._pending, self.op.serial_loops(whole=True))
            self._pending[:] = 0

    def before_host_write(self) -> None:
        """(`OperatorState` calls it before a slot or budget is set from the host.)"""
        self.flush()

    @ti.kernel
    def _scan(self, e: ti.i32, serial: ti.template()):
        gx, nx, gy, ny = ti.static(self.op.gx, self.op.nx, self.op.gy, self.op.ny)
        ti.loop_config(serialize=True)
        for r in range(4):
            self.res[e, r, 0] = 0
            self.res[e, r, 1] = _NO_CELL
        h_tol = self.par[e, 0]
        phi_tol = self.par[e, 1]
        hmin = self.par[e, 2]
        ti.loop_config(serialize=serial)  # as the operator's loops (operator.py)
        for i, j in ti.ndrange((gx, gx + nx), (gy, gy + ny)):
            self._check(e, i, j, h_tol, phi_tol, hmin)

    @ti.kernel
    def _scan_members(self, on: ti.types.ndarray(), serial: ti.template()):
        """`_scan` of every member e with on[e] != 0, in one launch."""
        gx, nx, gy, ny = ti.static(self.op.gx, self.op.nx, self.op.gy, self.op.ny)
        ti.loop_config(serialize=True)
        for e in range(self.op.M):
            if on[e] != 0:
                for r in range(4):
                    self.res[e, r, 0] = 0
                    self.res[e, r, 1] = _NO_CELL
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange((gx, gx + nx), (gy, gy + ny), self.op.M):
            if on[e] != 0:
                self._check(e, i, j, self.par[e, 0], self.par[e, 1], self.par[e, 2])

    @ti.func
    def _check(self, e, i, j, h_tol, phi_tol, hmin):
        """Cell (i, j) of member e's slot 0 into its result table: the first rule it breaks
        counts it and keeps the smallest linear index."""
        gx, gy, ny = ti.static(self.op.gx, self.op.gy, self.op.ny)
        v = self.op.q[0, i, j, e]
        idx = (i - gx) * ny + (j - gy)
        bad = 0
        for c in ti.static(range(self.op.nc)):
            if ti.math.isnan(v[c]) or ti.math.isinf(v[c]):
                bad = 1
        rule = -1
        if bad == 1:
            rule = NONFINITE
        elif v[0] < -h_tol:
            rule = NEG_H
        if ti.static(self.op.seg):
            h = v[0]
            hp = v[self.op.HPHI]
            if rule < 0 and h >= hmin:
                if hp < -phi_tol * h:
                    rule = PHI_LOW
                elif hp > (1.0 + phi_tol) * h:
                    rule = PHI_HIGH
        if rule >= 0:
            ti.atomic_add(self.res[e, rule, 0], 1)
            ti.atomic_min(self.res[e, rule, 1], idx)

    @ti.kernel
    def _keep(self, e: ti.i32, serial: ti.template()):
        ti.loop_config(serialize=serial)
        for i, j in ti.ndrange(self.op.NX, self.op.NY):
            self.good[i, j, e] = self.op.q[0, i, j, e]
        ti.loop_config(serialize=True)
        for b in range(NBUDGET):
            self.good_bud[e, b] = self.op.bud[e, 0, b]

    @ti.kernel
    def _keep_members(self, on: ti.types.ndarray(), serial: ti.template()):
        """`_keep` of every member e with on[e] != 0, in one launch."""
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange(self.op.NX, self.op.NY, self.op.M):
            if on[e] != 0:
                self.good[i, j, e] = self.op.q[0, i, j, e]
        ti.loop_config(serialize=True)
        for e, b in ti.ndrange(self.op.M, NBUDGET):
            if on[e] != 0:
                self.good_bud[e, b] = self.op.bud[e, 0, b]

    @ti.kernel
    def _good_out(self, e: ti.i32, out: ti.types.ndarray(), serial: ti.template()):
        """out[c, i, j] := component c of member e's last good state, every cell."""
        ti.loop_config(serialize=serial)
        for i, j in ti.ndrange(self.op.NX, self.op.NY):
            v = self.good[i, j, e]
            for c in ti.static(range(self.op.nc)):
                out[c, i, j] = v[c]


class StateGuard:
    """Bounds and finiteness check of slot 0 of member ``member`` of ``op``, plus a device
    copy of its last good state (the state's `GuardStore`). ``op``: the operator's state
    (`tiseg.solver.numerics.state.OperatorState`) or the operator.

    ``h_ref``: thickness scale [m] for the round-off tolerance on h; ``mass_tol``: relative
    tolerance of the mass balance (None: a default for the precision, 1e-6 in f64 and 1e-3 in
    f32; 0 or a negative value switches the mass check off).
    """

    def __init__(self, op, h_ref: float, mass_tol: float | None = None, member: int = 0):
        self.op = op = getattr(op, "state", op)
        self.member = int(member)  # the ensemble member whose state it checks
        self.store = op.observer(GuardStore)
        lay = op.lay
        self.lay = lay
        eps = float(np.finfo(op.np_fp).eps)
        # a few ulps: the scheme itself clamps exactly, so anything beyond this is a real breach
        self.h_tol = 16.0 * eps * h_ref
        self.phi_tol = 16.0 * eps
        if mass_tol is None:
            mass_tol = 1e-6 if op.np_fp == np.float64 else 1e-3
        self.mass_tol = float(mass_tol)
        self.good_meta: dict | None = None  # t, steps, ... of the copy in the store
        self.set_params()

    def set_params(self, h_ref: float | None = None) -> None:
        """Take the operator's h_min again (after Simulation.set_parameters), and the
        thickness scale ``h_ref`` [m] of the round-off tolerance on h where given."""
        op, store = self.op, self.store
        if h_ref is not None:
            self.h_tol = 16.0 * float(np.finfo(op.np_fp).eps) * h_ref
        store.par_host[self.member] = (self.h_tol, self.phi_tol, op.cfgs[self.member].h_min)
        store.par.from_numpy(store.par_host)

    # ------------------------------------------------------------------ host side
    def scan(self, t: float, step: int) -> Violation | None:
        """Check slot 0; the first broken rule (in the order of RULES) or None."""
        self.op.check_alive()
        res = self.store.table(self.member)
        for rule in range(4):
            count, idx = int(res[rule, 0]), int(res[rule, 1])
            if count:
                return self._describe(rule, count, idx, t, step)
        return None

    def check_mass(
        self, totals: dict, initial: dict, budget: dict, t: float, step: int
    ) -> Violation | None:
        """Total mass against initial + inflow (a backstop for losses the scan cannot see)."""
        if not self.mass_tol > 0:
            return None
        expected = initial["mass"] + budget["mass_in"]
        scale = max(abs(initial["mass"]), abs(totals["mass"]), abs(budget["mass_in"]), 1e-300)
        rel = abs(totals["mass"] - expected) / scale
        if not rel <= self.mass_tol:  # also catches a NaN total
            return Violation(
                "mass balance", "mass", -1, -1, float("nan"), float("nan"), rel, 0, t, step
            )
        return None

    def keep(self, meta: dict) -> None:
        """Copy slot 0 and its budget into the last-good buffer (on the device)."""
        self.store.keep(self.member)
        self.good_meta = dict(meta)

    def last_good(self) -> tuple[np.ndarray, np.ndarray, dict] | None:
        """(q with ghosts (nc, NX, NY) in float64, budget, meta) of the last state that passed."""
        if self.good_meta is None:
            return None
        self.store.flush()
        q = np.empty((self.op.nc, self.op.NX, self.op.NY), dtype=self.op.np_fp)
        self.store._good_out(self.member, q, self.op.serial_loops(whole=True))
        bud = self.store.good_bud.to_numpy()[self.member]
        return q.astype(np.float64), bud.astype(np.float64), dict(self.good_meta)

    def _describe(self, rule: int, count: int, idx: int, t: float, step: int) -> Violation:
        lay = self.lay
        i, j = divmod(idx, lay.ny)
        q = self.op.get(0, self.member)[:, lay.gx + i, lay.gy + j]
        names = ["h", "hu"] + ([] if lay.is_1d else ["hv"]) + (["h*phi"] if lay.segregation else [])
        if rule == NONFINITE:
            c = int(np.argmax(~np.isfinite(q)))
            field, value = names[c], float(q[c])
        elif rule == NEG_H:
            field, value = "h", float(q[0])
        else:
            field, value = "phi", float(q[lay.HPHI] / q[0])
        cfg = self.op.cfgs[self.member]
        return Violation(
            RULES[rule], field, i, j, (i + 0.5) * cfg.dx, (j + 0.5) * cfg.dy, value, count, t, step
        )


def measure_overhead(sim, steps: int = 200) -> dict:
    """Wall time of one guard check against one time step of ``sim`` (which is advanced by
    ``steps`` steps without checks, then checked ``steps`` times). For the README's numbers."""
    import time

    every = sim.check_every
    sim.check_every = 0
    sim.step()  # compile everything before timing
    sim.guard.scan(sim.t, sim.stats.steps)
    sim.guard.keep({"t": sim.t})
    try:
        t0 = time.perf_counter()
        for _ in range(steps):
            sim.step()
        per_step = (time.perf_counter() - t0) / steps
        t0 = time.perf_counter()
        for _ in range(steps):
            sim.guard.scan(sim.t, sim.stats.steps)
            sim.guard.keep({"t": sim.t})
        per_check = (time.perf_counter() - t0) / steps
    finally:
        sim.check_every = every
    return {"step_s": per_step, "check_s": per_check, "ratio": per_check / per_step}


__all__ = ["StateGuard", "Violation", "RULES", "measure_overhead"]
