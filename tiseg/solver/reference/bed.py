"""NumPy twin of the bed's hydrostatic reconstruction (`tiseg.solver.numerics.bed`), written
independently of the kernels, for `tiseg.solver.reference.operator`.

Arrays are (nc, NX, NY) primitives and (NX, NY) bed heights with ghost cells; ``axis`` 1 is x,
2 is y, and a face m + 1/2 along it is stored at index m, as the reference's fluxes are.
"""

from __future__ import annotations

import numpy as np


def _shifted(a: np.ndarray, axis: int, k: int) -> np.ndarray:
    """a[m + k] at index m along ``axis`` (counted on a's own axes), zero where m + k falls
    outside."""
    out = np.zeros_like(a)
    n = a.shape[axis]
    dst = [slice(None)] * a.ndim
    src = [slice(None)] * a.ndim
    if k >= 0:
        dst[axis], src[axis] = slice(0, n - k), slice(k, n)
    else:
        dst[axis], src[axis] = slice(-k, n), slice(0, n + k)
    out[tuple(dst)] = a[tuple(src)]
    return out


def eta_slopes(ref, w: np.ndarray, bed: np.ndarray, axis: int, solid=None) -> np.ndarray:
    """The undivided slope of eta = h + b along ``axis`` (1: x, 2: y) on the cells with both
    neighbours, zero on the outermost layers: the reconstruction's slope where the three
    cells are wet, minmod where one is dry; zero at first order. A solid neighbour is level
    with the cell (``solid``: the (NX, NY) mask, or None)."""
    eta = w[0] + bed
    out = np.zeros_like(eta)
    if not ref.rec.slopes:
        return out
    ax = axis - 1  # axes of the (NX, NY) arrays
    em, ep = _shifted(eta, ax, -1), _shifted(eta, ax, 1)
    h = w[0]
    hmin3 = np.minimum(np.minimum(_shifted(h, ax, -1), h), _shifted(h, ax, 1))
    dm, dp = eta - em, ep - eta
    if solid is not None:
        dm = np.where(_shifted(solid, ax, -1), 0.0, dm)
        dp = np.where(_shifted(solid, ax, 1), 0.0, dp)
    vec = np.zeros((ref.lay.nc,) + eta.shape)
    vdm, vdp, vdc = vec.copy(), vec.copy(), vec.copy()
    vdm[0], vdp[0], vdc[0] = dm, dp, 0.5 * (dm + dp)
    rec = ref.rec.slope_np(ref.cfg, ref.lay, vdm, vdp, vdc)[0]
    mm = np.where(dm * dp > 0.0, np.sign(dm) * np.minimum(np.abs(dm), np.abs(dp)), 0.0)
    s = np.where(hmin3 > 0.0, rec, mm)
    inner = [slice(None)] * 2
    inner[ax] = slice(1, eta.shape[ax] - 1)
    out[tuple(inner)] = s[tuple(inner)]
    return out


def star_states(ref, wl, bl, wr, br, g=None):
    """(wl*, wr*, p_l, p_r): the edge states with h* = max(0, h + b - max(b_l, b_r)) and each
    side's pressure correction (1/2) g cos(zeta) (h^2 - h*^2); ``g``: the faces' gravity on a
    bend (ReferenceOperator.face_gravity)."""
    bs = np.maximum(bl, br)
    wls, wrs = wl.copy(), wr.copy()
    wls[0] = np.maximum(0.0, wl[0] + bl - bs)
    wrs[0] = np.maximum(0.0, wr[0] + br - bs)
    half_g = 0.5 * ref.gravity_part(g, 1)
    return wls, wrs, half_g * (wl[0] ** 2 - wls[0] ** 2), half_g * (wr[0] ** 2 - wrs[0] ** 2)


def bed_rate(ref, w, s, eta_s, bed, p_lo_face, p_hi_face, axis) -> np.ndarray:
    """The normal momentum rate of every cell from the bed along ``axis``: the centred source
    (1/2) g cos(zeta) (h_lo + h_hi)(b_lo - b_hi) of its own edges minus the difference of its
    faces' corrections (its side's), over the spacing. ``p_lo_face``, ``p_hi_face``: the
    corrections of each face (at index m) for its low and its high side."""
    ax = axis - 1
    h0 = w[0]
    h_lo, h_hi = h0 - 0.5 * s[0], h0 + 0.5 * s[0]
    eta = h0 + bed
    b_lo, b_hi = eta - 0.5 * eta_s - h_lo, eta + 0.5 * eta_s - h_hi
    centred = 0.5 * ref.gravity_part(ref.gcell, 1) * (h_lo + h_hi) * (b_lo - b_hi)
    faces = p_lo_face - _shifted(p_hi_face, ax, -1)
    spacing = ref.cfg.dx if axis == 1 else ref.cfg.dy
    return (centred - faces) / spacing
