"""A bed b(x, y) under the flow: the hydrostatic reconstruction that keeps a lake at rest.

With a bed of height b normal to the reference plane, the pressure (1/2) g cos(zeta) h^2 of
(6.2) acts on the free surface eta = h + b, and the momentum balance gains the source
-g cos(zeta) h grad b. Written naively, the flux and the source balance only to truncation
error, and a lake at rest (eta constant, u = 0) starts to move. The hydrostatic
reconstruction of Audusse, Bouchut, Bristeau, Klein & Perthame (2004, SIAM J. Sci. Comput.
25, 2050) balances them exactly and keeps h >= 0 with wet-dry fronts and emerged islands:

1. the edges of a cell: h from the scheme's own limited slope (which keeps h >= 0), eta from
   the same reconstruction applied to eta = h + b (minmod where a cell of the stencil is dry:
   its slope is zero where either side is level, so eta stays flat up to a shore), and
   b_edge = eta_edge - h_edge;
2. at a face between edge states (h_l, b_l) | (h_r, b_r): b* = max(b_l, b_r) and
   h*_l,r = max(0, h_l,r + b_l,r - b*); the numerical flux takes the states with h*;
3. each side adds its own pressure correction (1/2) g cos(zeta) (h_side^2 - h*_side^2) to the
   normal momentum flux it sees (so the flux is no longer one number for both cells: momentum
   is exchanged with the bed, as it physically is);
4. each cell adds the centred source (1/2) g cos(zeta) (h_lo + h_hi)(b_lo - b_hi) / D of its
   own edges along each direction (D the spacing), which makes the scheme second order.

At rest with eta constant the slope of eta vanishes, so every edge has eta_edge = eta, both
sides of a face have the same h*, the flux is the pressure of h*, and the corrections and the
centred source cancel the pressure differences (to round-off: the two sides round
differently). A dry cell higher than the lake (an island) gives h* = 0 at its faces. Where a
face carries no convective flux (`FiniteVolume.face_wet`) each side keeps the pressure of its
own edge, so the balance holds in films as well.

`BedFaces` holds the Taichi functions of steps 1-4, for the unsplit evaluation of L
(`finite_volume`) and the split sweeps (`split`), which store the two corrections of each face
in the state's ``pcx``/``pcy`` fields. `bed_with_ghosts` fills the ghost cells of b on the host
(periodic: the image; wall: the mirror image; otherwise the edge cell's value), for the kernels
and the NumPy twin (`tiseg.solver.reference.operator`) alike. A flat scene allocates nothing and
compiles none of it (``ti.static``).
"""

import numpy as np
import taichi as ti

from ...taichi_classes import data_oriented

from ...model.physics.params import Params


def bed_with_ghosts(b: np.ndarray, lay, bc) -> np.ndarray:
    """The bed (nx, ny) [m] on every cell (NX, NY): ghost cells from the boundaries ``bc``
    (x_lo, x_hi, y_lo, y_hi): the image across a periodic pair, the mirror image at a wall,
    the edge cell's value elsewhere (an inflow or outflow sees a bed that goes on level)."""
    b = np.asarray(b, dtype=float)
    if b.shape != (lay.nx, lay.ny):
        raise ValueError(f"bed of shape {b.shape}: expected (nx, ny) = {(lay.nx, lay.ny)}")
    out = np.zeros((lay.NX, lay.NY))
    ix, iy = lay.interior()
    out[ix, iy] = b
    for d, (g, n) in enumerate(((lay.gx, lay.nx), (lay.gy, lay.ny))):
        if g == 0:
            continue
        lo, hi = bc[2 * d], bc[2 * d + 1]
        a = np.moveaxis(out, d, 0)  # a view: writes go to out
        for k in range(g):
            if lo == "periodic":
                a[g - 1 - k] = a[g + n - 1 - k]
            elif lo == "wall":
                a[g - 1 - k] = a[g + k]
            else:
                a[g - 1 - k] = a[g]
            if hi == "periodic":
                a[g + n + k] = a[g + k]
            elif hi == "wall":
                a[g + n + k] = a[g + n - 1 - k]
            else:
                a[g + n + k] = a[g + n - 1]
    return out


@data_oriented
class BedFaces:
    def __init__(self, state, rec_slope):
        """``state``: the operator's fields (``w``, ``bed``, ``par``); ``rec_slope``: the
        reconstruction's slope function (None at first order), applied to eta."""
        self.state = state
        self._rec_slope = rec_slope
        self.first = rec_slope is None
        self.has_solid = state.solid is not None  # (Taichi scope has no `is not`)
        self.stored = state.es is not None  # the slopes of eta kept by the slopes pass

    @ti.func
    def eta_slope(self, e, i, j, d: ti.template()):
        """The slope of eta at cell (i, j) along d: kept by the unsplit scheme's slopes pass
        (`keep_slopes`), computed here in the split sweeps (each cell's once, in the
        predictor)."""
        s = ti.cast(0.0, self.state.fp)
        if ti.static(self.stored):
            s = self.state.es[i, j, e][d]
        else:
            s = self.eta_slope_of(e, i, j, d)
        return s

    @ti.func
    def keep_slopes(self, e, i, j, x: ti.template(), y: ti.template()):
        """Keep the slopes of eta at cell (i, j): along x where ``x``, along y where ``y``
        (the cells whose slopes of w the unsplit slopes pass takes)."""
        if ti.static(x):
            self.state.es[i, j, e][0] = self.eta_slope_of(e, i, j, 0)
        if ti.static(y):
            self.state.es[i, j, e][1] = self.eta_slope_of(e, i, j, 1)

    @ti.func
    def eta_slope_of(self, e, i, j, d: ti.template()):
        """The limited undivided slope of eta = h + b at cell (i, j) along d (0 at first
        order), by the scene's reconstruction."""
        s = ti.cast(0.0, self.state.fp)
        if ti.static(not self.first):
            im, jm, ip, jp = i - 1, j, i + 1, j
            if ti.static(d == 1):
                im, jm, ip, jp = i, j - 1, i, j + 1
            e0 = self.state.w[i, j, e][0] + self.state.bed[i, j]
            dm = ti.Vector.zero(self.state.fp, self.state.nc)
            dp = dm
            dc = dm
            dm[0] = e0 - (self.state.w[im, jm, e][0] + self.state.bed[im, jm])
            dp[0] = (self.state.w[ip, jp, e][0] + self.state.bed[ip, jp]) - e0
            if ti.static(self.has_solid):  # a wall is level with the cell it faces
                if self.state.solid[im, jm] != 0:
                    dm[0] = 0.0
                if self.state.solid[ip, jp] != 0:
                    dp[0] = 0.0
            dc[0] = 0.5 * (dm[0] + dp[0])
            hmin3 = ti.min(
                ti.min(self.state.w[im, jm, e][0], self.state.w[i, j, e][0]),
                self.state.w[ip, jp, e][0],
            )
            if hmin3 > 0.0:
                s = self._rec_slope(e, dm, dp, dc)[0]
            elif dm[0] * dp[0] > 0.0:
                # a dry cell in the stencil (a shore, an island): minmod, whose slope is zero
                # where either side is level, so a lake keeps eta flat up to its shore (a
                # WENO-type slope is not zero there)
                s = ti.min(ti.abs(dm[0]), ti.abs(dp[0]))
                if dm[0] < 0.0:
                    s = -s
        return s

    @ti.func
    def edges(self, e, i, j, d: ti.template(), h_lo, h_hi):
        """(b_lo, b_hi): the bed at the low and high edge of cell (i, j) along d whose
        reconstructed thicknesses are h_lo, h_hi (step 1)."""
        e0 = self.state.w[i, j, e][0] + self.state.bed[i, j]
        s = self.eta_slope(e, i, j, d)
        return e0 - 0.5 * s - h_lo, e0 + 0.5 * s - h_hi

    @ti.func
    def edge_lo(self, e, i, j, d: ti.template(), h):
        """The bed at the low edge of cell (i, j) along d, whose reconstructed thickness is h."""
        return (
            self.state.w[i, j, e][0] + self.state.bed[i, j] - 0.5 * self.eta_slope(e, i, j, d) - h
        )

    @ti.func
    def edge_hi(self, e, i, j, d: ti.template(), h):
        """The bed at the high edge of cell (i, j) along d, whose reconstructed thickness is h."""
        return (
            self.state.w[i, j, e][0] + self.state.bed[i, j] + 0.5 * self.eta_slope(e, i, j, d) - h
        )

    @ti.func
    def star(self, wl, bl, wr, br, g):
        """(wl*, wr*, [p_l, p_r]): the edge states with h* (step 2) and each side's pressure
        correction (1/2) g cos(zeta) (h^2 - h*^2) (step 3); g: the face's gravity
        (tiseg.solver.numerics.gravity: on a bend its g cos zeta, without the kappa u^2 of the
        flux, which vanishes at rest)."""
        bs = ti.max(bl, br)
        wls = wl
        wrs = wr
        wls[0] = ti.max(0.0, wl[0] + bl - bs)
        wrs[0] = ti.max(0.0, wr[0] + br - bs)
        half_g = 0.5 * g[1]
        p = ti.Vector(
            [half_g * (wl[0] * wl[0] - wls[0] * wls[0]), half_g * (wr[0] * wr[0] - wrs[0] * wrs[0])]
        )
        return wls, wrs, p

    @ti.func
    def dry(self, hl, hr, g):
        """The corrections of a face without convective flux: each side's whole pressure."""
        half_g = 0.5 * g[1]
        return ti.Vector([half_g * hl * hl, half_g * hr * hr])

    @ti.func
    def centred(self, h_lo, h_hi, b_lo, b_hi, g):
        """The centred source of a cell along a direction, times the spacing (step 4):
        (1/2) g cos(zeta) (h_lo + h_hi)(b_lo - b_hi), g the cell's gravity."""
        return 0.5 * g[1] * (h_lo + h_hi) * (b_lo - b_hi)

    # ---------------------------------------------------------------- the split sweeps
    @ti.func
    def _inv(self, e, d: ti.template()):
        inv = self.state.par[e, Params.INV_DX]
        if ti.static(d == 1):
            inv = self.state.par[e, Params.INV_DY]
        return inv

    @ti.func
    def predicted(self, e, i, j, d: ti.template(), h_lo, h_hi, dt):
        """Hancock's predictor of cell (i, j) along d, whose unevolved edges have the
        thicknesses h_lo, h_hi: keeps the bed at those edges (``eb``, for the faces and the
        update) and returns the normal momentum the bed gives both edges over dt / 2 (its
        centred source), which balances their pressure difference in a lake at rest."""
        e0 = self.state.w[i, j, e][0] + self.state.bed[i, j]
        s = self.eta_slope(e, i, j, d)
        b_lo = e0 - 0.5 * s - h_lo
        b_hi = e0 + 0.5 * s - h_hi
        self.state.eb[i, j, e] = ti.Vector([b_lo, b_hi])
        g = self.state.grav.cell(e, i)
        return (0.5 * dt * self._inv(e, d)) * self.centred(h_lo, h_hi, b_lo, b_hi, g)

    @ti.func
    def sweep_face(self, e, i, j, i1, j1, d: ti.template(), wl, wr, wet, kind, g):
        """The predicted edges wl | wr of the face (i, j) | (i1, j1) along d with h* (where
        the face is ``wet``), and its two pressure corrections into pcx / pcy; a wall
        (``kind``, tiseg.solver.numerics.walls) sees the fluid side's bed on both sides."""
        wls = wl
        wrs = wr
        bl = self.state.eb[i, j, e][1]
        br = self.state.eb[i1, j1, e][0]
        if kind == 1:  # the high cell is solid
            br = bl
        elif kind != 0:
            bl = br
        p = self.dry(wl[0], wr[0], g)
        if kind == 3:  # two solid cells
            p = p * 0.0
        if wet:
            wls, wrs, p = self.star(wl, bl, wr, br, g)
        if ti.static(d == 0):
            self.state.pcx[i, j, e] = p
        else:
            self.state.pcy[i, j, e] = p
        return wls, wrs

    @ti.func
    def sweep_rate(self, e, i, j, im, jm, d: ti.template(), lam, dt):
        """The normal momentum the bed gives cell (i, j) over a sweep along d (its low
        neighbour (im, jm)): its faces' corrections and the centred source of its predicted
        edges."""
        pc_hi = ti.Vector.zero(self.state.fp, 2)
        pc_lo = pc_hi
        if ti.static(d == 0):
            pc_hi = self.state.pcx[i, j, e]
            pc_lo = self.state.pcx[im, jm, e]
        else:
            pc_hi = self.state.pcy[i, j, e]
            pc_lo = self.state.pcy[im, jm, e]
        eb = self.state.eb[i, j, e]
        g = self.state.grav.cell(e, i)
        c = self.centred(self.state.ew[i, j, e][0], self.state.ee[i, j, e][0], eb[0], eb[1], g)
        return (dt * self._inv(e, d)) * c - lam * (pc_hi[0] - pc_lo[1])
