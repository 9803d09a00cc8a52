"""Reconstructions of the edge states (``numerics.reconstruction``) as components: one class per
slope, one registry line each.

A cell's edge values along a direction are w0 -+ s/2, s an undivided slope of the primitives w
from the cell and its two neighbours, w_m, w0, w_p. The operator computes the one-sided and
central differences dm = w0 - w_m, dp = w_p - w0, dc = (w_p - w_m)/2, asks the chosen
reconstruction for s, and then limits s so that the edges keep h >= 0 and 0 <= phi <= 1
(`limit_edges_np` and the operator's ``slope``, the same for every reconstruction). Each
reconstruction holds:

* ``slopes``: whether it has slopes at all (first order has none: the operator then stores no
  slope fields and reads the cell values as edge values);
* ``taichi(ti, par, lay, fp)``: its Taichi function ``slope(dm, dp, dc)``, reading its
  run-time numbers from the operator's parameter field (``slots``, indices of
  `tiseg.model.physics.params.Params`);
* ``slope_np(cfg, lay, dm, dp, dc)``: its NumPy twin, written apart from the Taichi function.

`RECONSTRUCTIONS` is the registry the scene's allowed values come from. This module imports
no Taichi.
"""

import numpy as np

from ...model.physics.params import Params


class FirstOrder:
    """Piecewise constant: the edge values are the cell's own (no slopes)."""

    name = "first-order"
    slopes = False
    slots: tuple[str, ...] = ()

    def taichi(self, ti, par, lay, fp):
        return None  # the operator compiles no slope

    def slope_np(self, cfg, lay, dm, dp, dc):
        return np.zeros_like(dc)


class Minmod:
    """Generalised minmod: s = minmod(theta dm, dc, theta dp), theta = ``numerics.theta`` in
    [1, 2] (1 the most dissipative); zero where the three differ in sign."""

    name = "minmod"
    slopes = True
    slots = ("THETA",)

    def taichi(self, ti, par, lay, fp):
        @ti.func
        def slope(e, dm, dp, dc):
            th = par[e, Params.THETA]
            a = th * dm
            b = dc
            c = th * dp
            pos = (a > 0) & (b > 0) & (c > 0)
            neg = (a < 0) & (b < 0) & (c < 0)
            mn = ti.min(ti.min(a, b), c)
            mx = ti.max(ti.max(a, b), c)
            return ti.select(pos, mn, ti.select(neg, mx, 0.0))

        return slope

    def slope_np(self, cfg, lay, dm, dp, dc):
        th = cfg.theta
        a, b, cc = th * dm, dc, th * dp
        same = (np.sign(a) == np.sign(b)) & (np.sign(b) == np.sign(cc))
        mag = np.minimum(np.minimum(np.abs(a), np.abs(b)), np.abs(cc))
        return np.where(same, np.sign(b) * mag, 0.0)


class Weno:
    """WENO-type weighted slope (docs/numerics.md section 4): s = (a_m dm + a_p dp + a_c dc) /
    (a_m + a_p + a_c) with a_m = 1/4 P_m^-1, a_p = 1/4 P_p^-1, a_c = 1/2 P_c^-1, P = (eps +
    b^2)^2 and b the difference made dimensionless by h_ref (h), u_ref (velocities) or 1 (phi);
    eps = ``numerics.weno_eps``."""

    name = "weno"
    slopes = True
    slots = ("WENO_EPS", "INV_H_REF", "INV_U_REF")

    def taichi(self, ti, par, lay, fp):
        nc, seg, P = lay.nc, lay.segregation, lay.HPHI

        @ti.func
        def slope(e, dm, dp, dc):
            eps = par[e, Params.WENO_EPS]
            isc = ti.Vector.zero(fp, nc) + par[e, Params.INV_U_REF]
            isc[0] = par[e, Params.INV_H_REF]
            if ti.static(seg):
                isc[P] = 1.0
            bm = dm * isc
            bp = dp * isc
            bc = dc * isc
            # multiplying the weighted mean through by P_m P_p P_c leaves one division. P >=
            # eps^2 = 1e-12 and |b| stays far below 1e9, so the products neither under- nor
            # overflow, even in f32.
            pm = (eps + bm * bm) * (eps + bm * bm)
            pp = (eps + bp * bp) * (eps + bp * bp)
            pc = (eps + bc * bc) * (eps + bc * bc)
            wm = 0.25 * pp * pc
            wp = 0.25 * pm * pc
            wc = 0.5 * pm * pp
            return (wm * dm + wp * dp + wc * dc) / (wm + wp + wc)

        return slope

    def slope_np(self, cfg, lay, dm, dp, dc):
        scale = np.ones(lay.nc)
        scale[0] = cfg.h_ref
        scale[1:] = cfg.u_ref
        if lay.segregation:
            scale[lay.HPHI] = 1.0
        sc = scale.reshape((-1,) + (1,) * (dc.ndim - 1))
        eps = cfg.weno_eps
        am = 0.25 / (eps + (dm / sc) ** 2) ** 2
        ap = 0.25 / (eps + (dp / sc) ** 2) ** 2
        ac = 0.5 / (eps + (dc / sc) ** 2) ** 2
        return (am * dm + ap * dp + ac * dc) / (am + ap + ac)


def limit_edges_np(lay, s, w0):
    """The edge limiter of every reconstruction, in place: |s_h| <= 2 h (edge h >= 0) and
    |s_phi| <= 2 min(phi, 1 - phi) (edge phi in [0, 1])."""
    s[0] = np.clip(s[0], -2.0 * w0[0], 2.0 * w0[0])
    if lay.segregation:
        p = w0[lay.HPHI]
        lim = 2.0 * np.minimum(p, 1.0 - p)
        s[lay.HPHI] = np.clip(s[lay.HPHI], -lim, lim)
    return s


RECONSTRUCTIONS: dict[str, FirstOrder | Minmod | Weno] = {
    r.name: r for r in (FirstOrder(), Minmod(), Weno())
}
