"""Two-dimensional dispersion relation, appendix B.

Normal modes (h1, u1, v1, phi1) = (H, U, V, Phi) exp(sigma t + i (k_x x + k_y y)) of the 2D
equations (6.1)-(6.3) linearised about (1, 1, 0, phi0) satisfy A W = sigma W with the 4x4 matrix
(dimensionless, scalings (5.1))::

    H: [ -i kx,             -i kx,                                -i ky,                                0 ]
    U: [ -(mu_h + i kx)/F^2, -mu_u/F^2 - i kx - (kx^2 + ky^2/2)/R,  -kx ky/(2R),                          -mu_phi/F^2 ]
    V: [ -i ky/F^2,          -kx ky/(2R),                          -tan(zeta)/F^2 - i kx - (kx^2/2 + ky^2)/R, 0 ]
    Phi:[ i kx G0,           i kx G0,                              i ky G0,                              i kx (G0' - 1) ]

The 1/2 factors come from the strain rate D = (grad u + grad u^T)/2 of (6.6) in nu h^{3/2} D, and
tan(zeta)/F^2 from the transverse friction -mu_b v/|u| of (6.4b) linearised at mu_b = tan(zeta).
For k_y = 0 it splits into the 1D matrix (5.21) and the V mode
sigma = -tan(zeta)/F^2 - i k_x - k_x^2/(2R).

Its characteristic polynomial is the quartic (B2) with the coefficients (B3)-(B5). Three of the
printed coefficients of (B5) disagree with the determinant of this matrix;
`expansion_coefficients` uses the corrected forms:

* f_{1,1,2}: the printed "-2 mu_u" inside (2 - G0')(tan + 2R - 2 mu_u) must be "+2 mu_u";
* f_{1,2,2}: the printed (3 - G0') must be (3 - 2 G0');
* f_{1,3,0}: the printed 2 F^2 R (3 G0' - 2) must be 2 F^2 R (3 G0' - 4).

None of them affects the paper's conclusions (the asymptotics (B7)-(B11) hold, see the tests).
"""

from __future__ import annotations

import mpmath
import numpy as np

from .base import BaseState
from .dispersion1d import DPS, base_parameters, needs_extended


def matrix(bs: BaseState, kx, ky) -> np.ndarray:
    """The 4x4 matrix above, broadcast over kx, ky; shape broadcast(kx, ky).shape + (4, 4)."""
    kx, ky = np.broadcast_arrays(np.asarray(kx, dtype=float), np.asarray(ky, dtype=float))
    F2, r = bs.F**2, bs.inv_R
    A = np.zeros(kx.shape + (4, 4), dtype=complex)
    A[..., 0, 0] = -1j * kx
    A[..., 0, 1] = -1j * kx
    A[..., 0, 2] = -1j * ky
    A[..., 1, 0] = -(bs.mu_h + 1j * kx) / F2
    A[..., 1, 1] = -bs.mu_u / F2 - 1j * kx - (kx**2 + 0.5 * ky**2) * r
    A[..., 1, 2] = -0.5 * kx * ky * r
    A[..., 1, 3] = -bs.mu_phi / F2
    A[..., 2, 0] = -1j * ky / F2
    A[..., 2, 1] = -0.5 * kx * ky * r
    A[..., 2, 2] = -bs.tan_zeta / F2 - 1j * kx - (0.5 * kx**2 + ky**2) * r
    A[..., 3, 0] = 1j * kx * bs.G0
    A[..., 3, 1] = 1j * kx * bs.G0
    A[..., 3, 2] = 1j * ky * bs.G0
    A[..., 3, 3] = 1j * kx * (bs.dG0 - 1.0)
    return A


def expansion_coefficients(bs: BaseState, extended: bool = False) -> dict:
    """f_{i,j,l} of (B5), written with r = 1/R so that the inviscid limit r = 0 is regular.

    Keys "f012" etc. stand for f_{0,1,2}. The three corrections listed in the module docstring are
    applied (marked "corrected" below). extended=True evaluates in mpmath.
    """
    p = base_parameters(bs, extended)
    F2, r, g, dg = p["F"] ** 2, p["r"], p["G0"], p["dG0"]
    mh, mu, mp, t = p["mu_h"], p["mu_u"], p["mu_phi"], p["tan_zeta"]
    F4, a = F2 * F2, 1 - dg
    return {
        # (B5a)
        "f012": mu / F4 * a,
        "f014": a * r / (2 * F2),
        "f020": t / F4 * a * (mh - mu),
        "f022": a / (2 * F2) * (r * (mh - 2 * mu - t) - 2),
        "f024": -a * r**2 / 2,
        "f030": a / F4 * ((mh - mu) * F2 + (1 - F2) * t),
        "f032": a * r / (2 * F2) * (2 - 3 * F2),
        "f040": a / (2 * F2) * (2 * (F2 - 1) + r * (-2 * t + mh - mu)),
        "f042": -a * r**2,
        "f050": a * r / (2 * F2) * (1 - 3 * F2),
        "f060": -a * r**2 / 2,
        # (B5b)
        "f102": mu / F4,
        "f104": r / (2 * F2),
        "f110": t / F4 * (-mh + (2 - dg) * mu + g * mp),
        # corrected: (2 - G0')(tan + 2R + 2 mu_u) / (2F^2 R), the paper prints -2 mu_u
        "f112": ((2 - dg) * (r * t + 2 + 2 * r * mu) - r * mh + r * g * mp) / (2 * F2),
        "f114": (2 - dg) * r**2 / 2,
        "f120": (
            (2 - dg) * F2 * mh + (2 * dg - 3) * F2 * mu - g * F2 * mp + t * (1 + (2 * dg - 3) * F2)
        )
        / F4,
        # corrected: (3 - 2 G0'), the paper prints (3 - G0')
        "f122": r / (2 * F2) * (2 - 3 * (3 - 2 * dg) * F2),
        # corrected: 2 F^2 R (3 G0' - 4), the paper prints (3 G0' - 2)
        "f130": ((2 - dg) * (2 + r * (2 * t + mu)) - r * mh + r * g * mp + 2 * F2 * (3 * dg - 4))
        / (2 * F2),
        "f132": (2 - dg) * r**2,
        "f140": r / (2 * F2) * (1 + 3 * F2 * (2 * dg - 3)),
        "f150": (2 - dg) * r**2 / 2,
        # (B5c)
        "f200": t / F4 * mu,
        "f202": (r * t + 2 + 2 * r * mu) / (2 * F2),
        "f204": r**2 / 2,
        "f210": ((3 - dg) * (mu + t) - mh + g * mp) / F2,
        "f212": 3 * (3 - dg) * r / 2,
        "f220": (r * mu + 2 * r * t + 2 * (1 + 3 * F2 * (dg - 2))) / (2 * F2),
        "f222": r**2,
        "f230": 3 * (3 - dg) * r / 2,
        "f240": r**2 / 2,
        # (B5d)
        "f300": (t + mu) / F2,
        "f302": 3 * r / 2,
        "f310": 4 - dg,
        "f320": 3 * r / 2,
    }


def char_poly_coefficients(bs: BaseState, kx, ky, extended: bool = False, c: dict | None = None):
    """(f0, f1, f2, f3) of f(sigma) = f0 + f1 sigma + f2 sigma^2 + f3 sigma^3 + sigma^4, (B2)-(B4).

    Works on numpy arrays (extended=False) or on mpmath scalars (extended=True).
    """
    if c is None:
        c = expansion_coefficients(bs, extended)
    I = mpmath.mpc(0, 1) if extended else 1j
    if not extended:
        kx, ky = np.asarray(kx, dtype=float), np.asarray(ky, dtype=float)
    y2 = ky**2
    y4 = y2 * y2
    # (B4a-f): the k_y dependence of each f_{i,j}
    f01 = c["f012"] * y2 + c["f014"] * y4
    f02 = c["f020"] + c["f022"] * y2 + c["f024"] * y4
    f03 = c["f030"] + c["f032"] * y2
    f04 = c["f040"] + c["f042"] * y2
    f10 = c["f102"] * y2 + c["f104"] * y4
    f11 = c["f110"] + c["f112"] * y2 + c["f114"] * y4
    f12 = c["f120"] + c["f122"] * y2
    f13 = c["f130"] + c["f132"] * y2
    f20 = c["f200"] + c["f202"] * y2 + c["f204"] * y4
    f21 = c["f210"] + c["f212"] * y2
    f22 = c["f220"] + c["f222"] * y2
    f30 = c["f300"] + c["f302"] * y2
    # (B3): powers of k_x
    x = kx
    f0 = (
        I * f01 * x
        + f02 * x**2
        + I * f03 * x**3
        + f04 * x**4
        + I * c["f050"] * x**5
        + c["f060"] * x**6
    )
    f1 = f10 + I * f11 * x + f12 * x**2 + I * f13 * x**3 + c["f140"] * x**4 + I * c["f150"] * x**5
    f2 = f20 + I * f21 * x + f22 * x**2 + I * c["f230"] * x**3 + c["f240"] * x**4
    f3 = f30 + I * c["f310"] * x + c["f320"] * x**2
    return f0, f1, f2, f3


def _roots_mp_one(bs: BaseState, kx: float, ky: float, guess=None, c=None) -> list:
    with mpmath.workdps(DPS):
        if c is None:
            c = expansion_coefficients(bs, extended=True)
        f0, f1, f2, f3 = char_poly_coefficients(bs, mpmath.mpf(kx), mpmath.mpf(ky), True, c)
        init = None if guess is None else [mpmath.mpc(complex(z)) for z in guess]
        try:
            return mpmath.polyroots(
                [mpmath.mpf(1), f3, f2, f1, f0], maxsteps=100, extraprec=2 * DPS, roots_init=init
            )
        except mpmath.libmp.NoConvergence:
            return mpmath.polyroots(
                [mpmath.mpf(1), f3, f2, f1, f0], maxsteps=500, extraprec=4 * DPS
            )


def roots(bs: BaseState, kx, ky, extended=False) -> np.ndarray:
    """The four sigma at each (kx, ky), shape broadcast + (4,), by decreasing real part.

    extended: False (numpy eigvals), True (mpmath roots of the corrected quartic (B2)-(B5)) or
    "auto" (mpmath where double round-off ~ eps |k|^2/R is not negligible, see
    `tiseg.model.stability.dispersion1d.needs_extended`).
    """
    kx, ky = np.broadcast_arrays(np.asarray(kx, dtype=float), np.asarray(ky, dtype=float))
    s = np.linalg.eigvals(matrix(bs, kx, ky))
    idx = np.argsort(-s.real, axis=-1, kind="stable")
    s = np.take_along_axis(s, idx, axis=-1)
    if extended:
        with mpmath.workdps(DPS):
            c = expansion_coefficients(bs, extended=True)
        fx, fy = kx.reshape(-1), ky.reshape(-1)
        fs = s.reshape(-1, 4)
        redo = (
            needs_extended(bs, np.hypot(fx, fy), fs[:, 0].real)
            if extended == "auto"
            else np.ones(fx.shape, dtype=bool)
        )
        for i in np.nonzero(redo)[0]:
            fs[i] = [complex(z) for z in _roots_mp_one(bs, fx[i], fy[i], fs[i], c)]
        s = fs.reshape(kx.shape + (4,))
    idx = np.argsort(-s.real, axis=-1, kind="stable")
    return np.take_along_axis(s, idx, axis=-1)


def sigma_M(bs: BaseState, kx, ky, extended=False) -> np.ndarray:
    """Growth rate max Re sigma over the four roots of (B2)."""
    return roots(bs, kx, ky, extended)[..., 0].real


def cross_slope_roots(bs: BaseState, ky):
    """The exact roots at k_x = 0, (B9): 0, -(mu_u/F^2 + k_y^2/(2R)) and sigma^(+/-).

    Returns an array (..., 4) ordered [0, sigma^(1), sigma^(+), sigma^(-)]. Written with 1/R so
    that nu = 0 works: sigma^(+/-) = (-(F^2 k_y^2 / R + tan) +/- sqrt(...)) / (2 F^2).
    """
    ky = np.asarray(ky, dtype=float)
    F2, r, t = bs.F**2, bs.inv_R, bs.tan_zeta
    b = F2 * ky**2 * r + t
    disc = np.sqrt((b**2 - 4 * F2 * ky**2).astype(complex))
    out = np.zeros(ky.shape + (4,), dtype=complex)
    out[..., 1] = -(bs.mu_u / F2 + 0.5 * ky**2 * r)
    out[..., 2] = (-b + disc) / (2 * F2)
    out[..., 3] = (-b - disc) / (2 * F2)
    return out


__all__ = [
    "matrix",
    "expansion_coefficients",
    "char_poly_coefficients",
    "roots",
    "sigma_M",
    "cross_slope_roots",
]
