"""Boundary conditions (``boundary.x_lo`` ... ``boundary.y_hi``) as components: one class per
condition, one registry line each.

The grid has g ghost layers on each side of each direction (`tiseg.solver.numerics.config.
Layout`); a boundary condition fills the ghost cell k (k = 0 next to the interior) of its side,
given the index m across the direction. Each condition holds:

* ``taichi(ti, op, d, side)``: its Taichi function ``fill(e, s, k, m)`` writing the ghost cell
  of slot s of member e in the operator's state field (``side`` 0 low, 1 high; ``d`` 0 = x, 1 = y); the
  operator's ghost pass calls the four sides' functions, composed with ``ti.static`` at
  construction;
* ``fill_np(ref, q, t, d, side, k)``: its NumPy twin on a whole layer of ghost cells of an
  array shaped (nc, NX, NY), as the reference operator fills them;
* ``mirrors``: the ghost cell is the mirror image of an interior cell (a wall), so a split
  sweep's predictor mirrors the source there too (`tiseg.solver.numerics.split`);
* ``periodic``: the ghost cell is another interior cell (a face across the boundary is one
  face of two cells);
* ``prescribed``: the ghost cells hold a state given by the scene (an inflow, low x only).

`BOUNDARIES` is the registry the scene's allowed values come from. This module imports no
Taichi.
"""

from ...errors import InputError
from ...model.physics.params import Params


def _extent(lay, d: int) -> tuple[int, int]:
    """(ghost layers g, interior cells n) along d."""
    return (lay.gx, lay.nx) if d == 0 else (lay.gy, lay.ny)


def _layer(d: int, a):
    """The index of the layer a along d of an array shaped (nc, NX, NY)."""
    return (slice(None), a) if d == 0 else (slice(None), slice(None), a)


class _Copy:
    """A condition whose ghost cell k is a copy of an interior cell (``source``), with the
    normal momentum reversed if it ``mirrors``."""

    mirrors = False
    periodic = False
    prescribed = False
    slots: tuple[str, ...] = ()

    def source(self, g: int, n: int, side: int) -> tuple[int, int]:
        """(a, b): ghost k of ``side`` copies the interior cell a + b k along d."""
        raise NotImplementedError

    def taichi(self, ti, op, d: int, side: int):
        g, n = _extent(op.lay, d)
        q = op.q
        comp = 1 if d == 0 else op.lay.HV  # the normal momentum
        mirrors = self.mirrors
        a, b = self.source(g, n, side)  # the cell copied: a + b k
        ga, gb = (g - 1, -1) if side == 0 else (n + g, 1)  # the ghost cell: ga + gb k

        @ti.func
        def fill(e, s, k, m):
            ghost = ga + gb * k
            inner = a + b * k
            if ti.static(d == 0):
                v = q[s, inner, m, e]
                if ti.static(mirrors):
                    v[comp] = -v[comp]
                q[s, ghost, m, e] = v
            else:
                v = q[s, m, inner, e]
                if ti.static(mirrors):
                    v[comp] = -v[comp]
                q[s, m, ghost, e] = v

        return fill

    def fill_np(self, ref, q, t: float, d: int, side: int, k: int) -> None:
        g, n = _extent(ref.lay, d)
        ghost = g - 1 - k if side == 0 else n + g + k
        a, b = self.source(g, n, side)
        q[_layer(d, ghost)] = q[_layer(d, a + b * k)]
        if self.mirrors:
            q[(ref.lay.HU if d == 0 else ref.lay.HV,) + _layer(d, ghost)[1:]] *= -1


class Outflow(_Copy):
    """Zero gradient: every ghost cell copies the interior cell next to the boundary."""

    name = "outflow"

    def source(self, g, n, side):
        return (g, 0) if side == 0 else (n + g - 1, 0)


class Periodic(_Copy):
    """The grid wraps round: ghost k copies the interior cell k + 1 cells in from the other
    side."""

    name = "periodic"
    periodic = True

    def source(self, g, n, side):
        return (n + g - 1, -1) if side == 0 else (g, 1)


class Wall(_Copy):
    """A reflecting wall: ghost k is the mirror image of the interior cell k + 1 cells in, its
    normal momentum reversed, so no mass crosses the boundary face."""

    name = "wall"
    mirrors = True

    def source(self, g, n, side):
        return (g, 1) if side == 0 else (n + g - 1, -1)


class Inflow:
    """The inflow of (6.8)-(6.9) at low x: h from the ramp at the stage time (run-time slot
    IN_H), u = inflow.u (IN_U), the concentration profile per row (the operator's
    ``inflow_prof`` field, with segregation), on the interior rows; nothing in the corners.
    Once the inflow stops (IN_ON = 0) it is a wall: no material leaks upstream. A localised
    inlet (``cfg.inflow_rows``, inflow.width and inflow.y0) fills only its rows so; the other
    interior rows are a wall. The full-width inlet compiles to the same kernel as without."""

    name = "inflow"
    mirrors = False
    periodic = False
    prescribed = True
    slots = ("IN_H", "IN_U", "IN_ON")

    def taichi(self, ti, op, d: int, side: int):
        if not (d == 0 and side == 0):
            raise InputError("an inflow is a condition of boundary.x_lo only")
        wall = BOUNDARIES["wall"].taichi(ti, op, d, side)
        q, par, fp, lay = op.q, op.par, op.fp, op.lay
        g, gy, ny, nc, seg, P = lay.gx, lay.gy, lay.ny, lay.nc, lay.segregation, lay.HPHI
        rows = op.cfg.inflow_rows
        full = rows is None
        lo, hi = (0, ny) if full else rows

        @ti.func
        def fill(e, s, k, m):
            if par[e, Params.IN_ON] > 0.5:
                if ti.static(full):
                    v = ti.Vector.zero(fp, nc)
                    if gy <= m < gy + ny:
                        h = par[e, Params.IN_H]
                        v[0] = h
                        v[1] = h * par[e, Params.IN_U]
                        if ti.static(seg):
                            v[P] = h * op.inflow_prof[e, m]
                    q[s, g - 1 - k, m, e] = v
                else:
                    if gy + lo <= m < gy + hi:
                        v = ti.Vector.zero(fp, nc)
                        h = par[e, Params.IN_H]
                        v[0] = h
                        v[1] = h * par[e, Params.IN_U]
                        if ti.static(seg):
                            v[P] = h * op.inflow_prof[e, m]
                        q[s, g - 1 - k, m, e] = v
                    elif gy <= m < gy + ny:
                        wall(e, s, k, m)
                    else:
                        q[s, g - 1 - k, m, e] = ti.Vector.zero(fp, nc)
            else:
                wall(e, s, k, m)

        return fill

    def fill_np(self, ref, q, t: float, d: int, side: int, k: int) -> None:
        c, lay = ref.cfg, ref.lay
        if t > c.inflow_stop:
            BOUNDARIES["wall"].fill_np(ref, q, t, d, side, k)
            return
        il = lay.gx - 1 - k
        h, u, phi = c.inflow_state(t)
        if c.inflow_rows is not None:  # the wall first, then the inlet's rows over it
            BOUNDARIES["wall"].fill_np(ref, q, t, d, side, k)
            q[:, il, : lay.gy] = 0.0
            q[:, il, lay.gy + lay.ny :] = 0.0
        else:
            q[:, il] = 0.0
        lo, hi = (0, lay.ny) if c.inflow_rows is None else c.inflow_rows
        ys = slice(lay.gy + lo, lay.gy + hi)
        q[:, il, ys] = 0.0
        q[lay.H, il, ys] = h
        q[lay.HU, il, ys] = h * u
        if lay.segregation:
            q[lay.HPHI, il, ys] = h * c.inflow_phi_profile(ref.y)[lo:hi]


def inlet_rows(lay, rows) -> tuple[int, int]:
    """The array rows [lo, hi) of an inlet's ghost cells whose velocities the viscous
    sub-step takes from the interior (ViscousSubstep._inlet_velocities): the inlet's interior
    rows ``rows`` (all when None), with the ghost rows beyond the side it reaches."""
    lo, hi = (0, lay.ny) if rows is None else rows
    return (0 if lo == 0 else lay.gy + lo, lay.NY if hi == lay.ny else lay.gy + hi)


BOUNDARIES: dict[str, Inflow | Outflow | Periodic | Wall] = {
    b.name: b for b in (Inflow(), Outflow(), Periodic(), Wall())
}
