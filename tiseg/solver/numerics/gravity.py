"""Gravity along and normal to the reference surface, per x column of cells and faces.

On the inclined plane of the paper it is two run-time numbers, g sin(zeta) and g cos(zeta)
(`Physics.g0`). A run-out's bend (``[terrain.runout]``, `tiseg.model.bed_line`) makes the
inclination a function of the arc length x: each column then has its own (g sin zeta(x),
g cos zeta(x), kappa(x)), kept in two fields filled on the host (the same numbers as the NumPy
reference; no transcendental functions in the kernels), one at the cell centres and one at
the x faces. The pointwise physics takes this vector g wherever it needs gravity
(`tiseg.model.physics.pointwise.Physics`): the normal load g cos zeta + kappa u^2 (Savage &
Hutter 1991; Gray, Wieland & Hutter 1999), clipped at zero, in the pressure, the wave speeds
and the friction. Without a bend no field exists and `cell` and `xface` return the plane's
numbers, so the kernels are those of the plane.
"""

import numpy as np
import taichi as ti

from ...taichi_classes import data_oriented

from ...model.bed_line import gravity_columns


@data_oriented
class Gravity:
    def __init__(self, state, ft):
        """``state``: the operator's fields (``par``, ``phys``); ``ft``: its field tree."""
        self.state = state
        self.bent = state.cfg.bend is not None
        shape = (state.M, state.NX)  # per member: g and zeta are run-time numbers
        self.cells = ft.vector(3, state.fp, shape) if self.bent else None
        self.faces = ft.vector(3, state.fp, shape) if self.bent else None

    def fill(self, cfgs) -> None:
        """The columns' gravity of each member's bend, ``cfgs`` the members' configurations
        (their g and zeta too: run-time numbers)."""
        if not self.bent:
            return
        lay = self.state.lay
        cols = [gravity_columns(c.bed_line(), c.g, c.dx, lay.gx, lay.NX) for c in cfgs]
        self.cells.from_numpy(np.stack([c for c, _ in cols]).astype(self.state.np_fp))
        self.faces.from_numpy(np.stack([f for _, f in cols]).astype(self.state.np_fp))

    @ti.func
    def cell(self, e, i):
        """(g sin zeta, g cos zeta, kappa) at the centre of column i of member e."""
        g = self.state.phys.g0(e)
        if ti.static(self.bent):
            g = self.cells[e, i]
        return g

    @ti.func
    def xface(self, e, i):
        """The same on the x face between columns i and i + 1."""
        g = self.state.phys.g0(e)
        if ti.static(self.bent):
            g = self.faces[e, i]
        return g

    @ti.func
    def face(self, e, i, d: ti.template()):
        """On the face between column i's cell and its neighbour along d: an x face, or the
        column's centre for a y face (the bend is along x)."""
        g = self.cell(e, i)
        if ti.static(d == 0):
            g = self.xface(e, i)
        return g
