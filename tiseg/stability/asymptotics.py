"""High-wavenumber asymptotics of the growth rates, sections 5.3-5.4 and appendices A.1-A.2, B.

All quantities are dimensionless (scalings (5.1)); ``bs`` is a `base.BaseState`.

1D inviscid (nu = 0):  Re sigma -> constants (5.28)-(5.30) (= (A12)-(A14)), except at F = Fc where
                       two of them diverge and Re sigma ~ +/- c k^{1/2} with c of (5.31) (= (A17)).
1D viscous (nu > 0):   Re sigma^(1) ~ -k^2/R (5.32), Re sigma^(2) -> -R/F^2 (5.33),
                       Re sigma^(3) ~ c2 / k^2 (5.34) (= (A27)), and at F = Fc ~ c4 / k^4 (5.35) (= (A31)).
2D viscous:            downslope k_x >> 1 (B7), (B8); cross-slope k_y >> 1 (B11).
"""

from __future__ import annotations

import math

from .base import BaseState

CRITICAL_TOL = 1e-12  # |F |G0'| - 1| below this counts as F = Fc (round-off of Fc = 1/|G0'|)


def is_critical(bs: BaseState) -> bool:
    return abs(bs.criticality()) < CRITICAL_TOL


def _ratio(num: float, den: float) -> float:
    # a vanishing denominator is the critical (ill-posed) case: the limit does not exist
    return num / den if den != 0.0 else math.nan


def inviscid_limits(bs: BaseState) -> tuple[float, float, float]:
    """Limits of Re sigma^(1,2,3) as k -> inf for nu = 0, (5.28), (5.29), (5.30).

    At F = Fc the two formulas whose denominator vanishes are returned as nan (the roots grow like
    +/- k^{1/2} instead, see `critical_sqrt_coefficient`).
    """
    F, g, dg = bs.F, bs.G0, bs.dG0
    mh, mu, mp = bs.mu_h, bs.mu_u, bs.mu_phi
    if is_critical(bs):
        a = F * dg - 1.0
        b = F * dg + 1.0
        # exactly one of F G0' -/+ 1 is (nearly) zero; (5.30)'s denominator F^2 G0'^2 - 1 always is
        a = 0.0 if abs(a) < CRITICAL_TOL else a
        b = 0.0 if abs(b) < CRITICAL_TOL else b
    else:
        a, b = F * dg - 1.0, F * dg + 1.0
    s1 = _ratio(a * (F * mh - mu) + F * g * (1 - F) * mp, 2 * F**2 * a)  # (5.28)
    s2 = _ratio(-b * (F * mh + mu) + F * g * (1 + F) * mp, 2 * F**2 * b)  # (5.29)
    s3 = _ratio(g * (1 - dg) * mp, 0.0 if is_critical(bs) else F**2 * dg**2 - 1)  # (5.30)
    return s1, s2, s3


def inviscid_supremum(bs: BaseState) -> float:
    """Largest of (5.28)-(5.30); +inf at F = Fc where sigma_M grows like k^{1/2} (5.31)."""
    if is_critical(bs):
        return math.inf
    return max(inviscid_limits(bs))


def critical_sqrt_coefficient(bs: BaseState) -> float:
    """c of Re sigma^(+/-) ~ +/- c k^{1/2} at F = Fc, nu = 0: c = |G0 G0' (1 - G0') mu_phi|^{1/2}/2, (5.31)."""
    return 0.5 * math.sqrt(abs(bs.G0 * bs.dG0 * (1 - bs.dG0) * bs.mu_phi))


def viscous_root1(bs: BaseState, k):
    """Re sigma^(1) ~ -k^2/R, (5.32) (= (A19))."""
    return -(k**2) * bs.inv_R


def viscous_root2_limit(bs: BaseState) -> float:
    """Re sigma^(2) -> -R/F^2, (5.33) (= (A23))."""
    return -bs.R / bs.F**2


def viscous_k2_coefficient(bs: BaseState) -> float:
    """c2 of Re sigma^(3) ~ c2/k^2: R^2 G0 (1-G0') (F^2 G0'^2 - 1) mu_phi / (F^4 G0'^2), (5.34)/(A27).

    Positive for F < Fc (unstable tail), negative for F > Fc (cutoff), zero at F = Fc.
    """
    F, R, g, dg = bs.F, bs.R, bs.G0, bs.dG0
    return R**2 * g * (1 - dg) * (F**2 * dg**2 - 1) * bs.mu_phi / (F**4 * dg**2)


def viscous_k4_coefficient(bs: BaseState) -> float:
    """c4 of Re sigma^(3) ~ c4/k^4 at F = Fc: 2 R^3 G0^2 G0'^2 (1-G0')^2 mu_phi^2, (5.35)/(A31)."""
    return 2 * bs.R**3 * bs.G0**2 * bs.dG0**2 * (1 - bs.dG0) ** 2 * bs.mu_phi**2


# ---- two dimensions (appendix B) ----------------------------------------------------------------
def downslope_2d(bs: BaseState) -> dict:
    """Leading behaviour of the four 2D roots for k_x >> 1 at fixed k_y, (B7).

    Re sigma^(1) ~ a1 k_x^2, Re sigma^(2) ~ a2 k_x^2, Re sigma^(3) -> a3, Re sigma^(4) ~ a4 / k_x^2,
    independent of k_y; a4 is the 1D coefficient (5.34). The extra root sigma^(2) is the
    cross-slope velocity mode, damped by the transverse viscosity nu h^{3/2}/2.
    """
    return {
        "a1": -bs.inv_R,
        "a2": -0.5 * bs.inv_R,
        "a3": viscous_root2_limit(bs),
        "a4": viscous_k2_coefficient(bs),
    }


def critical_2d_coefficient(bs: BaseState, ky: float) -> float:
    """c of Re sigma^(4) ~ c/k_x^4 at F = Fc, k_x >> 1 (B8):
    2 R^3 G0^2 G0'^2 (1-G0')^2 mu_phi^2 - R^2 G0 G0'^2 (1-G0') mu_phi k_y^2."""
    R, g, dg, mp = bs.R, bs.G0, bs.dG0, bs.mu_phi
    return (
        2 * R**3 * g**2 * dg**2 * (1 - dg) ** 2 * mp**2 - R**2 * g * dg**2 * (1 - dg) * mp * ky**2
    )


def cross_slope_2d(bs: BaseState, kx: float) -> dict:
    """Leading behaviour for k_y >> 1 at fixed k_x > 0, (B11).

    Re sigma^(1) ~ b1 k_y^2, Re sigma^(2) ~ b2 k_y^2, Re sigma^(3) -> b3 and
    Re sigma^(4) ~ b4 / k_y^2 with b4 = -R^2 G0 (1-G0') mu_phi k_x^2 / (R^2 + F^4 G0'^2 k_x^2).
    """
    R, F, g, dg = bs.R, bs.F, bs.G0, bs.dG0
    b4 = -(R**2) * g * (1 - dg) * bs.mu_phi * kx**2 / (R**2 + F**4 * dg**2 * kx**2)
    return {"b1": -bs.inv_R, "b2": -0.5 * bs.inv_R, "b3": viscous_root2_limit(bs), "b4": b4}


__all__ = [
    "inviscid_limits",
    "inviscid_supremum",
    "critical_sqrt_coefficient",
    "viscous_root1",
    "viscous_root2_limit",
    "viscous_k2_coefficient",
    "viscous_k4_coefficient",
    "downslope_2d",
    "critical_2d_coefficient",
    "cross_slope_2d",
    "is_critical",
]
