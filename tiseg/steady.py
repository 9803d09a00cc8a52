"""Steady uniform flows, section 4.

For given thickness h0 and concentration phi0 the force balance tan(zeta) = mu_b(h0, F, phi0)
(4.2) with the friction (3.4), (3.7) is the quadratic A F^2 + B h0 F + C h0^2 = 0 (4.4)-(4.7);
its positive root (4.9) exists only for phi0 > phi0* (4.8). The steady velocity is
u0 = F sqrt(g h0 cos zeta) (4.3). F is exactly proportional to h0 at fixed phi0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import InputError, require
from .material import TABLE1, Material


def check_thickness(h0: float, name: str = "h0") -> None:
    require(
        isinstance(h0, (int, float)) and math.isfinite(h0) and h0 > 0,
        f"{name}={h0!r}: thickness must be a positive number of metres",
    )


def check_concentration(phi0: float, name: str = "phi0") -> None:
    require(
        isinstance(phi0, (int, float)) and math.isfinite(phi0) and 0.0 <= phi0 <= 1.0,
        f"{name}={phi0!r}: concentration must lie in [0, 1]",
    )


def quadratic_coefficients(phi0: float, m: Material = TABLE1) -> tuple[float, float, float]:
    """A, B, C of (4.5)-(4.7) (B in 1/m, C in 1/m^2)."""
    s, l, t = m.small, m.large, m.tan_zeta
    A = phi0 * s.mu2 + (1 - phi0) * l.mu2 - t
    B = (
        phi0 * (s.M * s.mu1 + l.M * s.mu2)
        + (1 - phi0) * (s.M * l.mu2 + l.M * l.mu1)
        - (s.M + l.M) * t
    )
    C = (phi0 * s.mu1 + (1 - phi0) * l.mu1 - t) * s.M * l.M
    return A, B, C


def phi0_star(m: Material = TABLE1) -> float:
    """Smallest concentration that can flow steadily, (4.8)."""
    return (m.large.mu1 - m.tan_zeta) / (m.large.mu1 - m.small.mu1)


def froude_per_thickness(phi0: float, m: Material = TABLE1) -> float:
    """F / h0 [1/m] from (4.9); raises when no steady uniform flow exists."""
    check_concentration(phi0)
    A, B, C = quadratic_coefficients(phi0, m)
    disc = B * B - 4 * A * C
    root = (-B + math.sqrt(disc)) / (2 * A) if (A > 0 and disc >= 0) else float("nan")
    if not (root > 0):
        raise InputError(f"no steady uniform flow at phi0={phi0}: {_why_no_steady(phi0, m)}")
    return root


def _why_no_steady(phi0: float, m: Material) -> str:
    """Why the balance (4.2) has no positive root, in words. With A and C of (4.5), (4.7) that
    is A <= 0 or C >= 0: the slope is steeper than the mixture's dynamic friction angle (the
    flow accelerates), or not steeper than its static one (it stops). phi0* (4.8) is named
    only where raising phi0 to it helps (0 < phi0* < 1): at zeta = 80 deg it is -26.9, at
    10 deg 1.99, numbers that mean nothing as concentrations."""
    s, l = m.small, m.large
    both = (
        f"{s.zeta1_deg:g}, {s.zeta2_deg:g} deg small and {l.zeta1_deg:g}, {l.zeta2_deg:g} deg large"
    )
    slope = f"the slope zeta={m.zeta_deg:g} deg"
    mu2 = phi0 * s.mu2 + (1 - phi0) * l.mu2
    if m.tan_zeta >= mu2:
        return (
            f"{slope} is steeper than the friction can hold (its dynamic angle is "
            f"{math.degrees(math.atan(mu2)):.4g} deg at this concentration; zeta1, zeta2 = "
            f"{both}), so the flow accelerates without limit; a steady flow needs a gentler slope"
            + ("" if m.tan_zeta >= max(s.mu2, l.mu2) else " or another concentration")
        )
    star = phi0_star(m) if l.mu1 != s.mu1 else math.nan
    if s.mu1 < l.mu1 and 0 < star < 1:
        return (
            f"it needs phi0 > phi0*={star:.4f} (4.8) at zeta={m.zeta_deg} deg (too many "
            "frictional large particles)"
        )
    mu1 = phi0 * s.mu1 + (1 - phi0) * l.mu1
    return (
        f"{slope} is gentler than the friction's static angle "
        f"({math.degrees(math.atan(mu1)):.4g} deg at this concentration; zeta1, zeta2 = "
        f"{both}), so the flow comes to rest; a steady flow needs a steeper slope"
    )


def froude(h0: float, phi0: float, m: Material = TABLE1) -> float:
    """Steady uniform Froude number F(h0, phi0), (4.9)."""
    check_thickness(h0)
    return h0 * froude_per_thickness(phi0, m)


def velocity(h0: float, phi0: float, m: Material = TABLE1) -> float:
    """Steady uniform depth-averaged velocity u0 = F sqrt(g h0 cos zeta) [m/s], (4.3)."""
    return froude(h0, phi0, m) * math.sqrt(m.g * h0 * m.cos_zeta)


def critical_froude(phi0: float, m: Material = TABLE1) -> float:
    """Fc = 1/|G'(phi0)|, (5.27); infinite where G'(phi0) = 0."""
    check_concentration(phi0)
    d = abs(float(m.dG(phi0)))
    return math.inf if d == 0 else 1.0 / d


@dataclass(frozen=True)
class SteadyState:
    h0: float  # [m]
    phi0: float
    F: float  # (4.9)
    u0: float  # [m/s]
    phi0_star: float  # (4.8)
    Fc: float  # (5.27)
    h0_at_Fc: float  # thickness at which F = Fc for this phi0 [m]

    def as_dict(self) -> dict:
        return {
            k: (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in self.__dict__.items()
        }


def steady_state(h0: float, phi0: float, m: Material = TABLE1) -> SteadyState:
    """All section-4 quantities for (h0, phi0); raises `InputError` if none exists."""
    check_thickness(h0)
    check_concentration(phi0)
    per = froude_per_thickness(phi0, m)
    F = h0 * per
    Fc = critical_froude(phi0, m)
    return SteadyState(
        h0=h0,
        phi0=phi0,
        F=F,
        u0=F * math.sqrt(m.g * h0 * m.cos_zeta),
        phi0_star=phi0_star(m),
        Fc=Fc,
        h0_at_Fc=Fc / per,
    )


__all__ = [
    "SteadyState",
    "steady_state",
    "froude",
    "velocity",
    "phi0_star",
    "critical_froude",
    "quadratic_coefficients",
    "froude_per_thickness",
    "InputError",
]
