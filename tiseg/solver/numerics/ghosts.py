"""The ghost cells of a slot, filled by the boundary conditions of the four sides.

A collaborator of `tiseg.solver.numerics.operator.TaichiOperator` that receives the operator's
state (`state.OperatorState`): each side's component (`tiseg.solver.numerics.boundaries`)
returns the Taichi function that fills one ghost cell, composed here once the fields exist
(`GhostCells.compose`), and `GhostCells.fill` calls them in every kernel that needs the ghost
cells (an evaluation's preparation, a sweep, the wet scan).
"""

import taichi as ti

from ...taichi_classes import data_oriented


@data_oriented
class GhostCells:
    def __init__(self, state):
        self.state = state
        self._fill = None

    def compose(self) -> None:
        """The ghost fillers of (x_lo, x_hi[, y_lo, y_hi]), fixed at construction: the kernels
        call them through ``ti.static`` choices, so a condition not chosen leaves no code."""
        st = self.state
        dims = (0,) if st.is_1d else (0, 1)
        self._fill = tuple(
            st.bcs[2 * d + side].taichi(ti, st, d, side) for d in dims for side in (0, 1)
        )

    @ti.func
    def fill(self, s):
        """Ghost cells of slot s of every member from the boundary conditions (two top-level
        loops): each side's component (tiseg.solver.numerics.boundaries) fills its cells, low
        side first."""
        st = self.state  # (a Python object in Taichi scope: no code)
        gx, gy = ti.static(st.gx, st.gy)
        ti.loop_config(serialize=st.strip_serial)  # 2 columns of cells
        for k, j, e in ti.ndrange(gx, (0, st.NY), st.M):
            if st.runs(e):  # (a batch's finished members keep theirs)
                self._fill[0](e, s, k, j)
                self._fill[1](e, s, k, j)
        if ti.static(not st.is_1d):
            ti.loop_config(serialize=st.strip_serial)  # 2 rows of cells
            for i, k, e in ti.ndrange((0, st.NX), gy, st.M):
                if st.runs(e):
                    self._fill[2](e, s, k, i)
                    self._fill[3](e, s, k, i)
