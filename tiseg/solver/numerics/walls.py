"""Solid cells whose faces are walls: obstacles and raster nodata in a terrain.

A solid cell (``OperatorState.solid``) holds no material and is never updated. A face between
a fluid cell and a solid one is a wall, as the domain's wall boundaries are: the numerical flux
is taken between the fluid side's edge state and its mirror image (the same h and phi, the
normal velocity reversed), so no mass or h phi crosses it and the fluid feels the pressure and
the reflection of an impermeable, free-slip wall; the projected friction's near-rest face rules
(which would let mass through where the fluid moves towards a cell at rest) are not applied
there, and with a bed the wall face has no pressure correction (both sides see the fluid
side's bed). A face between two solid cells carries nothing. The viscous stress needs nothing:
its face coefficient is zero next to an empty cell (tiseg.model.physics.viscosity).

`SolidWalls` gives the Taichi functions of the unsplit evaluation of L
(`finite_volume.FiniteVolume`) and of the split sweeps (`split.SplitSweeps`); its NumPy twin is
in `tiseg.solver.reference.walls`. Without solid cells nothing is allocated or compiled.
"""

import taichi as ti

from ...taichi_classes import data_oriented

FLUID, WALL_HI, WALL_LO, SOLID = 0, 1, 2, 3  # the kinds of a face (low cell | high cell)


@data_oriented
class SolidWalls:
    def __init__(self, state):
        """``state``: the operator's fields (``solid``) and layout constants."""
        self.state = state

    @ti.func
    def kind(self, i0, j0, i1, j1):
        """FLUID, WALL_HI (the high cell is solid), WALL_LO (the low one is) or SOLID (both)
        for the face between cells (i0, j0) and (i1, j1)."""
        return ti.cast(self.state.solid[i1, j1], ti.i32) + 2 * ti.cast(
            self.state.solid[i0, j0], ti.i32
        )

    @ti.func
    def mirror(self, w, d: ti.template()):
        """The primitive state w seen in a wall normal to d: its normal velocity reversed."""
        out = w
        if ti.static(d == 0):
            out[1] = -w[1]
        else:
            out[self.state.HV] = -w[self.state.HV]
        return out

    @ti.func
    def faced(self, kind, wl, wr, d: ti.template()):
        """The edge states a face of ``kind`` takes: the fluid side and its mirror at a wall,
        as they are otherwise."""
        ol = wl
        orr = wr
        if kind == WALL_HI:
            orr = self.mirror(wl, d)
        elif kind == WALL_LO:
            ol = self.mirror(wr, d)
        return ol, orr

    @ti.func
    def is_solid(self, i, j):
        return self.state.solid[i, j] != 0
