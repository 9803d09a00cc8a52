"""One-dimensional dispersion relation, section 5.2 and appendix A.

Normal modes (h1, u1, phi1) = (H, U, Phi) exp(sigma t + i k x) of the linearised equations
(5.11)-(5.13) satisfy A W = sigma W with the 3x3 matrix (5.21); k and sigma are dimensionless in
the scalings (5.1). The growth rate is sigma_M(k) = max Re sigma (5.23).

Precision. ``numpy.linalg.eigvals`` is accurate to about eps * ||A|| ~ eps k^2 / R. For k >~ 50
this round-off is as large as the true growth rate, which decays like k^-2 (k^-4 at F = Fc), and
it even fakes a cutoff near k ~ 1e3-1e4 for F <= Fc. ``extended=True``
therefore solves the cubic (A1) with the coefficients (A2)-(A7) in mpmath at ~40 digits, and
``extended="auto"`` does so only where double precision cannot be trusted (`needs_extended`).
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
from scipy.optimize import brentq, minimize_scalar

from .asymptotics import CRITICAL_TOL, inviscid_supremum
from .base import BaseState

DPS = 40  # mpmath working digits for extended precision
AUTO_EXTENDED_K = 1e3  # "auto" always uses mpmath above this |k|
AUTO_RTOL = 1e8  # ... and where |sigma_M| < AUTO_RTOL * eps * ||A|| (relative error > ~1e-8)


def needs_extended(bs: BaseState, kabs, growth) -> np.ndarray:
    """Where a double-precision growth rate is not trustworthy (see the module docstring).

    eigvals is backward stable: its absolute error is ~eps ||A|| ~ eps (1 + |k| + |k|^2/R). Where
    the growth rate is not much larger than that (the k^-2, k^-4 tails), or |k| is very large,
    mpmath is used instead. Cheap enough that figures stay in double almost everywhere.
    """
    kabs = np.asarray(kabs, dtype=float)
    scale = np.finfo(float).eps * (1.0 + kabs + kabs**2 * bs.inv_R)
    return (kabs > AUTO_EXTENDED_K) | (np.abs(growth) < AUTO_RTOL * scale)


# ---- matrix and characteristic polynomial ------------------------------------------------------
def matrix(bs: BaseState, k) -> np.ndarray:
    """A(k) of (5.21), shape k.shape + (3, 3), complex. Unknowns W = (H, U, Phi)."""
    k = np.asarray(k, dtype=float)
    F2 = bs.F**2
    ik = 1j * k
    A = np.zeros(k.shape + (3, 3), dtype=complex)
    A[..., 0, 0] = -ik
    A[..., 0, 1] = -ik
    A[..., 1, 0] = -(bs.mu_h + ik) / F2
    A[..., 1, 1] = -bs.mu_u / F2 - ik - k**2 * bs.inv_R
    A[..., 1, 2] = -bs.mu_phi / F2
    A[..., 2, 0] = ik * bs.G0
    A[..., 2, 1] = ik * bs.G0
    A[..., 2, 2] = ik * (bs.dG0 - 1.0)
    return A


def base_parameters(bs: BaseState, extended: bool = False) -> dict:
    """F, 1/R, G0, G0', mu_h, mu_u, mu_phi, tan(zeta) as floats, or as mpmath numbers.

    The mpmath values are the same doubles, converted exactly: extended precision must evaluate the
    polynomial of *this* matrix exactly. Rounding the coefficients (A5)-(A7) to double instead
    perturbs f_{0,3} etc. by O(eps), which moves Re sigma^(3) by O(eps R) -- larger than the true
    k^-4 tail at F = Fc (e.g. 1.5e-14 against 2e-16 at k = 1e4).
    """
    vals = {
        "F": bs.F,
        "r": bs.inv_R,
        "G0": bs.G0,
        "dG0": bs.dG0,
        "mu_h": bs.mu_h,
        "mu_u": bs.mu_u,
        "mu_phi": bs.mu_phi,
        "tan_zeta": bs.tan_zeta,
    }
    if extended:
        return {n: mpmath.mpf(v) for n, v in vals.items()}
    return vals


def expansion_coefficients(bs: BaseState, extended: bool = False) -> dict:
    """The k-independent coefficients f_{i,j} of (A5)-(A7) (with 1/R = 0 when inviscid).

    extended=True evaluates them in mpmath at the current working precision.
    """
    p = base_parameters(bs, extended)
    F2, r, g, dg = p["F"] ** 2, p["r"], p["G0"], p["dG0"]
    mh, mu, mp = p["mu_h"], p["mu_u"], p["mu_phi"]
    return {
        "f02": -(1 - dg) * (mu - mh) / F2,  # (A5a)
        "f03": (1 - dg) * (1 - F2) / F2,  # (A5b)
        "f04": -(1 - dg) * r,  # (A5c)
        "f11": ((2 - dg) * mu - mh + g * mp) / F2,  # (A6a)
        "f12": 1 / F2 - 3 + 2 * dg,  # (A6b)
        "f13": (2 - dg) * r,  # (A6c)
        "f20": mu / F2,  # (A7a)
        "f21": 3 - dg,  # (A7b)
        "f22": r,  # (A7c)
    }


def char_poly_coefficients(bs: BaseState, k):
    """(f0, f1, f2) of f(sigma) = f0 + f1 sigma + f2 sigma^2 + sigma^3 = det(sigma I - A), (A1)-(A4)."""
    c = expansion_coefficients(bs)
    k = np.asarray(k, dtype=float)
    f0 = c["f02"] * k**2 + 1j * c["f03"] * k**3 + c["f04"] * k**4  # (A2)
    f1 = 1j * c["f11"] * k + c["f12"] * k**2 + 1j * c["f13"] * k**3  # (A3)
    f2 = c["f20"] + 1j * c["f21"] * k + c["f22"] * k**2  # (A4)
    return f0, f1, f2


# ---- roots ---------------------------------------------------------------------------------
def _sort_desc(s: np.ndarray) -> np.ndarray:
    """Order roots by decreasing real part (last axis) so that [..., 0] is the growth-rate root."""
    idx = np.argsort(-s.real, axis=-1, kind="stable")
    return np.take_along_axis(s, idx, axis=-1)


def _roots_mp_one(bs: BaseState, k: float, guess=None) -> list:
    """Roots of the cubic (A1) at one k, computed in mpmath with DPS digits."""
    with mpmath.workdps(DPS):
        K = mpmath.mpf(k)
        I = mpmath.mpc(0, 1)
        f = expansion_coefficients(bs, extended=True)
        f0 = f["f02"] * K**2 + I * f["f03"] * K**3 + f["f04"] * K**4
        f1 = I * f["f11"] * K + f["f12"] * K**2 + I * f["f13"] * K**3
        f2 = f["f20"] + I * f["f21"] * K + f["f22"] * K**2
        coeffs = [mpmath.mpf(1), f2, f1, f0]
        init = None if guess is None else [mpmath.mpc(complex(z)) for z in guess]
        try:
            rts = mpmath.polyroots(coeffs, maxsteps=100, extraprec=2 * DPS, roots_init=init)
        except mpmath.libmp.NoConvergence:
            rts = mpmath.polyroots(coeffs, maxsteps=500, extraprec=4 * DPS)
        return rts


def roots(bs: BaseState, k, extended=False) -> np.ndarray:
    """The three complex sigma of (5.20) at each k, shape k.shape + (3,), by decreasing Re.

    extended: False (double precision eigenvalues of (5.21)), True (mpmath polyroots of the cubic
    (A1) at DPS digits, result rounded to double) or "auto" (mpmath only where
    `needs_extended` says double precision is not good enough).
    """
    k = np.asarray(k, dtype=float)
    s = _sort_desc(np.linalg.eigvals(matrix(bs, k)))
    if extended:
        flat_k = k.reshape(-1)
        flat_s = s.reshape(-1, 3)
        redo = (
            needs_extended(bs, np.abs(flat_k), flat_s[:, 0].real)
            if extended == "auto"
            else np.ones(flat_k.shape, dtype=bool)
        )
        for i in np.nonzero(redo)[0]:
            kk = flat_k[i]
            # the double roots are excellent starting guesses for the mpmath iteration
            flat_s[i] = [complex(z) for z in _roots_mp_one(bs, kk, flat_s[i])]
        s = flat_s.reshape(k.shape + (3,))
    return _sort_desc(s)


def roots_mp(bs: BaseState, k: float) -> list:
    """The three roots at one k as mpmath numbers (DPS digits), by decreasing real part."""
    guess = np.linalg.eigvals(matrix(bs, np.array(float(k))))
    rts = _roots_mp_one(bs, float(k), guess)
    return sorted(rts, key=lambda z: -z.real)


def sigma_M(bs: BaseState, k, extended=False) -> np.ndarray:
    """Growth rate sigma_M(k) = max Re sigma, (5.23)."""
    return roots(bs, k, extended)[..., 0].real


# ---- most unstable mode and cutoff --------------------------------------------------------------
def _scan_grid(bs: BaseState, lo=1e-3, hi=1e3, n=241):
    k = np.logspace(math.log10(lo), math.log10(hi), n)
    # double precision is ample to locate a maximum of size O(1e-2) (round-off ~ eps k^2/R)
    return k, sigma_M(bs, k)


def _refine_max(bs: BaseState, k: np.ndarray, s: np.ndarray, i: int):
    """Bounded maximisation in log k around grid point i."""
    lo = math.log(k[max(i - 1, 0)])
    hi = math.log(k[min(i + 1, len(k) - 1)])
    res = minimize_scalar(
        lambda t: -float(sigma_M(bs, math.exp(t))),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-10},
    )
    kM, sM = math.exp(res.x), -float(res.fun)
    if sM < s[i]:  # keep the grid value if the optimiser did worse (flat or kinked maxima)
        kM, sM = float(k[i]), float(s[i])
    return kM, sM


def most_unstable(bs: BaseState):
    """(k_M, sigma_Max): the most unstable wavenumber and the maximal growth rate.

    Viscous (nu > 0): sigma_M -> 0 as k -> inf ((5.34), (5.35)), so the maximum is attained; it is
    located on a log-k grid and refined by bounded scalar maximisation in log k.

    Inviscid (nu = 0): sigma_M tends to the constants (5.28)-(5.30) and is typically increasing, so
    the supremum is the largest limit, approached as k -> inf: k_M = inf is returned. If an
    interior maximum exceeds that limit it is returned instead (finite k_M). At F = Fc the growth is
    unbounded (5.31) and (inf, inf) is returned.
    """
    if bs.inviscid:
        sup = inviscid_supremum(bs)
        if not math.isfinite(sup):
            return math.inf, math.inf
        k, s = _scan_grid(bs, 1e-3, 1e4, 281)
        i = int(np.argmax(s))
        if s[i] > sup * (1 + 1e-9) + 1e-14 and i < len(k) - 1:
            return _refine_max(bs, k, s, i)
        return math.inf, sup
    hi = 1e3
    k, s = _scan_grid(bs, 1e-3, hi)
    i = int(np.argmax(s))
    while i == len(k) - 1 and hi < 1e8:  # maximum still at the edge: look further out
        hi *= 100
        k, s = _scan_grid(bs, 1e-3, hi, 361)
        i = int(np.argmax(s))
    return _refine_max(bs, k, s, i)


def cutoff_analytic(bs: BaseState):
    """(k_c2+, k_c3+) of (A41), (A42); each is None where the square root is not real and positive.

    They are necessary conditions for a cutoff (a purely imaginary root), not sufficient ones,
    and both are undefined (None) for the inviscid model.

    (A41)/(A42) as printed are correct; two intermediate steps have typos that do not propagate:
    (A38) has C f_{2,1} where C f_{1,1} is meant, and the denominator of
    (A40) has f_{0,2} where f_{0,4} is meant. (A41) goes with C_1 = 1/F - 1 and (A42) with
    C_2 = -1/F - 1 of (A37): at k_c the neutral root is sigma = i C k_c (tested).
    """
    if bs.inviscid:
        return None, None
    F, R, dg, g = bs.F, bs.R, bs.dG0, bs.G0
    mh, mu, mp = bs.mu_h, bs.mu_u, bs.mu_phi
    out = []
    for d, num in (
        (F * dg - 1.0, (F * dg - 1.0) * (F * mh - mu) + F * g * (1 - F) * mp),  # (A41)
        (F * dg + 1.0, -(F * dg + 1.0) * (F * mh + mu) + F * g * (1 + F) * mp),
    ):  # (A42)
        if abs(d) < CRITICAL_TOL:  # F = Fc: k_c -> inf, i.e. no cutoff
            out.append(None)
            continue
        arg = R * num / d
        out.append(math.sqrt(arg) / F if arg > 0 else None)
    return tuple(out)


def cutoff(bs: BaseState, k_M: float | None = None):
    """Cutoff wavenumber k_c above which every mode decays (figures 9b, 11b), or None.

    Computed numerically: sigma_M is scanned on a log grid above k_M (mpmath where double precision
    is swamped) up to well beyond the analytic candidates (A41)/(A42) and the last change of sign
    from growth to decay is located with brentq. It only counts as a cutoff when the large-k tail
    decays, which (5.34), (5.35) show happens only for F > Fc; for F <= Fc and for nu = 0 there is
    none. The result agrees with (A41)/(A42) (tested), which serve as a cross-check.
    """
    if bs.inviscid or bs.criticality() <= CRITICAL_TOL:  # F <= Fc (within round-off of Fc)
        return None
    if k_M is None:
        k_M, _ = most_unstable(bs)
    cands = [c for c in cutoff_analytic(bs) if c is not None]
    # a cutoff is a purely imaginary root, so it can only sit at one of the analytic candidates:
    # scanning a few times beyond them is enough, and keeps the scan in double precision
    hi = max([50.0, 10.0 * k_M] + [4.0 * c for c in cands])
    k = np.logspace(math.log10(k_M), math.log10(hi), 161)
    s = sigma_M(bs, k, extended="auto")
    neg = s < 0
    if not neg[-1]:
        return None
    # last growing grid point: beyond it everything decays
    pos = np.nonzero(~neg)[0]
    if len(pos) == 0:
        return None
    j = int(pos[-1])
    a, b = float(k[j]), float(k[j + 1])

    def f(x):
        return float(sigma_M(bs, x, extended="auto"))

    return brentq(f, a, b, xtol=1e-13, rtol=1e-12, maxiter=200)


__all__ = [
    "matrix",
    "expansion_coefficients",
    "char_poly_coefficients",
    "roots",
    "roots_mp",
    "sigma_M",
    "base_parameters",
    "most_unstable",
    "cutoff",
    "cutoff_analytic",
    "inviscid_supremum",
    "AUTO_EXTENDED_K",
    "DPS",
    "needs_extended",
]
