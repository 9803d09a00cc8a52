"""Gauges: h, u, v and phi at fixed points after every step (``[[output.gauges]]``).

A sensor on a chute records a time series at one point; snapshots see the flow only at the
output times. A `Gauges` therefore reads the step state (slot 0) after every step, as the peak
fields do (`tiseg.run.peaks`), so a gauge series is exact per step whatever the output schedule.

Value at a point (x, y): the bilinear interpolation of the primitive fields of the four cell
centres around it, the fields exactly as fields.nc stores them (`StateArrays.fields`: u = hu / h
and v = hv / h where h >= numerics.h_eps, the solver's desingularised velocity in thinner
films (`state_access.output_velocity`), phi = h phi / h where h > 0, else 0, clipped to
[0, 1]; phi missing, NaN, where h < numerics.h_min). So interpolating a snapshot of
fields.nc by hand at a gauge gives that gauge's value at the snapshot time (when the snapshot is a step state). phi is NaN where
one of the four cells has no material. A point within half a cell of the chute's edge (beyond
the outermost centres) takes the value at the nearest centre along that axis (no
extrapolation, and the periodic copy is not used).

Cost: one launch per step that gathers the 4 corner cells of each gauge (4 vectors per gauge
copied to the host), and the interpolation on the host: nothing proportional to the grid. The
gauges read slot 0 only and write nothing the steps read, so the steps are the same bits with
gauges or without. They hold no state of their own, so a resumed run's series continues with
the same values; gauges.csv is cut back to the checkpoint's rows (`tiseg.run.run_folder`).
"""
# (no "from __future__ import annotations": Taichi reads kernel annotations as objects)

import numpy as np
import taichi as ti

from ..taichi_classes import data_oriented

from ..solver.field_tree import FieldTree
from .state_access import output_velocity

QUANTITIES = ("h", "u", "v", "phi")  # a gauge's columns, those of the run's fields


def stencil(coord: float, first: float, d: float, n: int) -> tuple[int, int, float]:
    """(i0, i1, w): the centres i0 <= i1 around ``coord`` on an axis of n centres at
    first + i d, and the weight w of i1 (1 - w of i0); clamped to the end centres outside."""
    s = (coord - first) / d
    if n == 1 or s <= 0.0:
        return 0, 0, 0.0
    if s >= n - 1:
        return n - 1, n - 1, 0.0
    i0 = min(int(np.floor(s)), n - 2)
    return i0, i0 + 1, float(s - i0)


@data_oriented
class Gauges:
    """The gauges ``points`` ((name, x, y), ...) on the grid of ``op`` (the operator's state,
    `tiseg.solver.numerics.state.OperatorState`, or the operator); ``dx``, ``dy``: the cell
    size [m]; ``h_min``: where phi is missing."""

    def __init__(self, op, points, dx: float, dy: float, h_min: float, member: int = 0):
        self.op = op
        self.member = int(member)  # the ensemble member whose state it reads
        self.names = tuple(p[0] for p in points)
        self.h_min = float(h_min)
        lay = op.lay
        cells, weights = [], []
        for _, x, y in points:
            i0, i1, wx = stencil(float(x), dx / 2, dx, lay.nx)
            j0, j1, wy = stencil(float(y), dy / 2, dy, lay.ny) if lay.ny > 1 else (0, 0, 0.0)
            cells += [(i0, j0), (i1, j0), (i0, j1), (i1, j1)]
            weights.append(((1 - wx) * (1 - wy), wx * (1 - wy), (1 - wx) * wy, wx * wy))
        self.weights = np.array(weights, dtype=np.float64)  # (gauges, 4)
        n = len(cells)
        ft = self.field_tree = FieldTree()  # freed with this object
        self.cells = ft.field(ti.i32, (n, 2))
        self.values = ft.vector(op.nc, op.fp, (n,))
        ft.finalize()
        ft.free_with(self)
        self.cells.from_numpy(np.array(cells, dtype=np.int32))

    @ti.kernel
    def _gather(self, e: ti.i32):
        """The conserved vectors of the corner cells, from member e's slot 0 (reads only)."""
        gx, gy = ti.static(self.op.gx, self.op.gy)
        for k in range(self.cells.shape[0]):
            self.values[k] = self.op.q[0, gx + self.cells[k, 0], gy + self.cells[k, 1], e]

    def read(self) -> dict[str, np.ndarray]:
        """{quantity: array (gauges,)} of the current step state, float64; the run's quantities
        only (no v in 1D, no phi without segregation)."""
        self._gather(self.member)
        q = self.values.to_numpy()  # (4 gauges, nc), the run's precision
        lay = self.op.lay
        h = q[:, lay.H]
        safe = np.where(h > 0, h, 1.0)
        h_eps = self.op.cfgs[self.member].h_eps
        corners = {"h": h, "u": output_velocity(h, q[:, lay.HU], h_eps)}
        if not lay.is_1d:
            corners["v"] = output_velocity(h, q[:, lay.HV], h_eps)
        if lay.segregation:
            phi = np.clip(np.where(h > 0, q[:, lay.HPHI] / safe, 0.0), 0.0, 1.0)
            corners["phi"] = np.where(h < self.h_min, np.nan, phi)
        w = self.weights
        # a corner of weight 0 adds nothing, not even its NaN (a point on a row of centres)
        return {
            name: np.where(w > 0, a.astype(np.float64).reshape(-1, 4) * w, 0.0).sum(axis=1)
            for name, a in corners.items()
        }

    def columns(self) -> tuple[str, ...]:
        """gauges.csv's columns: time, then ``<name>_<quantity>`` for each gauge."""
        lay = self.op.lay
        have = [q for q in QUANTITIES if (q != "v" or not lay.is_1d)]
        have = [q for q in have if q != "phi" or lay.segregation]
        return ("time",) + tuple(f"{n}_{q}" for n in self.names for q in have)

    def row(self, t: float) -> dict:
        """gauges.csv's row of the current step state at time t."""
        vals = self.read()
        row = {"time": float(t)}
        for i, n in enumerate(self.names):
            for q, a in vals.items():
                v = float(a[i])
                row[f"{n}_{q}"] = v if v == v else None  # NaN: an empty cell (no material)
        return row


__all__ = ["Gauges", "stencil", "QUANTITIES"]
