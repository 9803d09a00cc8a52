"""Peak fields of a run: the largest thickness and speed each cell reached, when the flow
arrived there, and the deposit it left at rest.

Hazard maps are drawn from these (the peak thickness and speed, the arrival time), and they
cannot be recovered from snapshots, which see the flow only at the output times. `PeakFields`
therefore updates them on the device after every step, from the step state (slot 0 of the
`tiseg.solver.numerics.operator.TaichiOperator`), so they are exact per step whatever the
output schedule. "Wet" means h >= numerics.h_min, the threshold of the fronts (6.10) and of
the fluxes (section 6.2).

* ``h_max`` [m]: the largest h over the step states from t = 0 on (0 where the chute stayed
  empty);
* ``speed_max`` [m/s]: the largest |u| = |(hu, hv)| / h (|hu| / h in 1D), the speed of the
  depth-averaged velocity of (6.1)-(6.2) as fields.nc stores it, over the step states in which
  the cell was wet; missing where it never was (the speed of a film thinner than h_min is not
  a speed of the flow);
* ``arrival_time`` [s]: the end time of the first step (t = 0 for the initial state) after
  which the cell was wet: the first time h >= h_min, to within the step that crossed it;
  missing where the flow never came;
* ``deposit_h`` [m] and, with segregation, ``deposit_phi``: h and phi of the current state
  where the material is at rest, wet with |u| <= `REST_SPEED`, the rest speed of the deposit
  analysis (`tiseg.post.analysis.deposit`); missing elsewhere. Taken from the state at the
  time the fields are read, so at the end of a run they are its final deposit.

Cost: one launch after each step over the cells the step could change (the active x range
and the 3 cells either side that a step's combinations write, `SlotAlgebra._combine_cells`),
a few loads and compares per cell: cells outside keep their bits, so their peaks cannot
change. With ``output.peak_fields = false`` a simulation has no `PeakFields`: no field is
allocated and no kernel compiled or run. Nothing here writes to the operator, so the steps
and the final state are the same bits with the peak fields on or off.

Resume: the three fields are part of a run's state, saved in ``checkpoint.npz`` in the run's
precision (`tiseg.run.checkpoint`), so a resumed run ends with the same bits.
"""
# (no "from __future__ import annotations": Taichi reads kernel annotations as objects)

import numpy as np
import taichi as ti

from ..taichi_classes import data_oriented

from ..model.material import REST_SPEED
from ..model.physics.params import Params
from ..solver.field_tree import FieldTree

NEVER = -1.0  # the stored arrival time of a cell the flow has not reached
PEAK_NAMES = ("h_max", "speed_max", "arrival_time")
CHECKPOINT_KEYS = {"h_max": "peak_h_max", "speed": "peak_speed_max", "arrival": "peak_arrival"}
STENCIL_HALO = 3  # cells either side of the active range that a step writes


@data_oriented
class PeakStore:
    """The running peaks of every member of an operator's state, on the device: fields
    (nx, ny, members), the members innermost as in the state. One per state
    (`OperatorState.observer`), which each member's `PeakFields` uses with its own index, so
    a batch traces and compiles these kernels once."""

    def __init__(self, state):
        self.op = state
        lay = state.lay
        shape = (lay.nx, lay.ny, state.M)
        ft = self.field_tree = FieldTree()  # freed with this object
        self.h_max = ft.field(state.fp, shape)
        self.speed = ft.field(state.fp, shape)
        self.arrival = ft.field(state.fp, shape)
        ft.finalize()
        ft.free_with(self)

    @ti.kernel
    def _update(
        self,
        e: ti.i32,
        t: float,
        fresh: ti.template(),
        whole: ti.template(),
        serial: ti.template(),
    ):
        """Fold the state of slot 0 of member e at time t into its peaks: on every interior
        cell (``whole``), else on the active x range and the cells a step writes beside it;
        ``fresh``: begin anew (every cell). The range and h_min are read on the device (the
        operator's fields): one argument to pass, since a launch's cost on small grids is
        mostly its arguments and set-up."""
        gx, nx, ny = ti.static(self.op.gx, self.op.nx, self.op.ny)
        lo, hi = gx, gx + nx
        if ti.static(not whole):
            lo, hi = self._written()
        hmin = self.op.par[e, Params.H_MIN]
        ti.loop_config(serialize=serial)
        for i, j in ti.ndrange((lo, hi), (0, ny)):
            self._fold(e, i, j, t, hmin, fresh)

    @ti.kernel
    def _update_members(
        self, ts: ti.types.ndarray(), on: ti.types.ndarray(), serial: ti.template()
    ):
        """`_update` after a step of each member e with on[e] != 0, at its time ts[e]: one
        launch for a batch's members (the active range is the batch's, as each member's
        own launch would read)."""
        lo, hi = self._written()
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange((lo, hi), (0, self.op.ny), self.op.M):
            if on[e] != 0:
                self._fold(e, i, j, ts[e], self.op.par[e, Params.H_MIN], False)

    @ti.func
    def _written(self):
        """The x range a step can have written: the active range and STENCIL_HALO cells
        beside it, within the interior."""
        gx, nx = ti.static(self.op.gx, self.op.nx)
        lo = ti.max(self.op.act[0] - STENCIL_HALO, gx)
        hi = ti.min(self.op.act[1] + STENCIL_HALO, gx + nx)
        return lo, hi

    @ti.func
    def _fold(self, e, i, j, t, hmin, fresh: ti.template()):
        """Cell (i, j) of member e's slot 0 at time t into its peaks, wet from h >= hmin
        (``fresh``: begin anew)."""
        gx, gy = ti.static(self.op.gx, self.op.gy)
        v = self.op.q[0, i, gy + j, e]
        h = v[0]
        k = i - gx
        if ti.static(fresh):
            self.h_max[k, j, e] = 0.0
            self.speed[k, j, e] = 0.0
            self.arrival[k, j, e] = NEVER
        if h > self.h_max[k, j, e]:  # (a NaN compares false: the guard reports it)
            self.h_max[k, j, e] = h
        if h >= hmin:
            m2 = v[1] * v[1]
            if ti.static(not self.op.is_1d):
                m2 += v[self.op.HV] * v[self.op.HV]
            s = ti.sqrt(m2) / h
            if s > self.speed[k, j, e]:
                self.speed[k, j, e] = s
            if self.arrival[k, j, e] < 0.0:
                self.arrival[k, j, e] = t

    def update_members(self, ts, on) -> None:
        """Fold in the state a step just ended with for each member e with on[e], at its time
        ts[e] (one launch; `_update_members`)."""
        ts = np.ascontiguousarray(ts, dtype=self.op.np_fp)
        on = np.ascontiguousarray(on, dtype=np.int32)
        self._update_members(ts, on, self.op.serial_loops())

    @ti.kernel
    def _copy(self, e: ti.i32, a: ti.types.ndarray(), out: ti.template(), serial: ti.template()):
        """``out``: a[0..2, k, j] := member e's h_max, speed, arrival; else the reverse."""
        ti.loop_config(serialize=serial)
        for k, j in ti.ndrange(self.op.nx, self.op.ny):
            if ti.static(out):
                a[0, k, j] = self.h_max[k, j, e]
                a[1, k, j] = self.speed[k, j, e]
                a[2, k, j] = self.arrival[k, j, e]
            else:
                self.h_max[k, j, e] = a[0, k, j]
                self.speed[k, j, e] = a[1, k, j]
                self.arrival[k, j, e] = a[2, k, j]


class PeakFields:
    """The running peaks of slot 0 of member ``member`` of ``op``, on the interior cells, in
    the run's precision. ``op``: the operator's state (`tiseg.solver.numerics.state
    .OperatorState`) or the operator. The fields are the state's `PeakStore`."""

    def __init__(self, op, member: int = 0):
        self.op = getattr(op, "state", op)
        self.member = int(member)  # the ensemble member whose state it folds in
        self.store = self.op.observer(PeakStore)
        self.shape = (self.op.lay.nx, self.op.lay.ny)
        self.launches = 0  # kernel launches of start() and update() (a test counts them)

    def start(self, t: float) -> None:
        """Begin anew from the state of slot 0 at time t (every cell)."""
        self.store._update(self.member, float(t), True, True, self.op.serial_loops(whole=True))
        self.launches += 1

    def update(self, t: float) -> None:
        """Fold in the state a step just ended with at time t: only the cells it could change
        (the operator's active range, as the step left it, and STENCIL_HALO cells beside it)."""
        self.store._update(self.member, t, False, False, self.op.serial_loops())
        self.launches += 1

    def _fields(self) -> np.ndarray:
        """h_max, speed, arrival as stored, (3, nx, ny) in the run's precision."""
        a = np.empty((3, *self.shape), dtype=self.op.np_fp)
        self.store._copy(self.member, a, True, self.op.serial_loops(whole=True))
        return a

    def arrays(self) -> dict[str, np.ndarray]:
        """``h_max``, ``speed_max``, ``arrival_time`` as float64 arrays (ny, nx), NaN where
        missing (never wet)."""
        h_max, speed, arrival = (f.astype(np.float64).T for f in self._fields())
        never = arrival < 0.0
        return {
            "h_max": h_max.copy(),
            "speed_max": np.where(never, np.nan, speed),
            "arrival_time": np.where(never, np.nan, arrival),
        }

    def state(self) -> dict[str, np.ndarray]:
        """The fields as stored (nx, ny), in the run's precision: the checkpoint's arrays."""
        a = self._fields()
        return {CHECKPOINT_KEYS[key]: a[k] for k, key in enumerate(("h_max", "speed", "arrival"))}

    def restore(self, arrays: dict) -> bool:
        """Inverse of `state`; False (and nothing changed) when ``arrays`` lacks them, a
        ValueError when one has the wrong shape."""
        keys = [CHECKPOINT_KEYS[key] for key in ("h_max", "speed", "arrival")]
        if not all(key in arrays for key in keys):
            return False
        data = [np.asarray(arrays[key]) for key in keys]
        for key, a in zip(keys, data):
            if a.shape != self.shape or a.dtype.kind != "f":
                raise ValueError(f"{key} is {a.dtype} {a.shape}, not {self.shape}")
        a = np.ascontiguousarray(np.stack(data).astype(self.op.np_fp))
        self.store._copy(self.member, a, False, self.op.serial_loops(whole=True))
        return True


def deposit(fields: dict, h_min: float, rest_speed: float = REST_SPEED) -> dict:
    """``deposit_h`` (and ``deposit_phi`` when ``fields`` has phi) of one state given as the
    primitive fields (ny, nx) of `tiseg.run.state_access.StateArrays.fields`: h and phi
    where the cell is wet (h >= h_min) and at rest (|u| <= rest_speed), NaN elsewhere."""
    h = np.asarray(fields["h"], dtype=float)
    speed = np.abs(np.asarray(fields["u"], dtype=float))
    if "v" in fields:
        speed = np.hypot(speed, np.asarray(fields["v"], dtype=float))
    rest = (h >= h_min) & (speed <= rest_speed)
    out = {"deposit_h": np.where(rest, h, np.nan)}
    if "phi" in fields:
        out["deposit_phi"] = np.where(rest, np.asarray(fields["phi"], dtype=float), np.nan)
    return out


__all__ = [
    "PeakFields",
    "deposit",
    "REST_SPEED",
    "PEAK_NAMES",
    "CHECKPOINT_KEYS",
]
