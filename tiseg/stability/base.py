"""Dimensionless base state of the linear stability analysis, sections 5.1-5.2.

With the scalings (5.1) (h = h0 h^, u = u0 u^, x = h0 x^, t = h0/u0 t^) the steady uniform flow
of section 4 becomes (h, u, phi) = (1, 1, phi0) and the linearised equations (5.11)-(5.13) depend
only on the handful of numbers collected in `BaseState`:

* F, the steady Froude number (4.9), and R = u0 sqrt(h0) / nu, the granular Reynolds number (5.7)
  (SI units for u0, h0, nu; R = inf for the inviscid model nu = 0);
* gamma^N = beta^N h0 / (L^N F) of (5.6), mu_b^N(1, 1) and Gamma^N of (5.18);
* the friction derivatives mu_h, mu_u, mu_phi of (5.15)-(5.17);
* G0 = G(phi0) and G0' = G'(phi0) of (5.14) (taken from the material, so alpha and the Bagnold
  transport function (2.18) are honoured), tan(zeta) and the critical Froude number Fc (5.27).

Because F is exactly proportional to h0 at fixed phi0, gamma^N and hence mu_h, mu_u, mu_phi depend
on phi0 only; h0 enters the stability problem only through F and R.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from ..errors import require
from ..material import TABLE1, Material
from ..steady import check_concentration, check_thickness, critical_froude, froude_per_thickness


@dataclass(frozen=True)
class BaseState:
    """Everything the dimensionless dispersion relations (5.21), (B2) need, plus SI context."""

    # SI inputs and steady state
    h0: float  # flow thickness [m]
    phi0: float  # small-particle concentration
    nu: float  # viscosity coefficient of (3.2) [m^(3/2)/s]; 0 = inviscid
    u0: float  # steady velocity [m/s], (4.3)
    # dimensionless numbers of section 5
    F: float  # Froude number (4.9)
    R: float  # Reynolds number (5.7); inf when nu == 0
    gamma_S: float  # gamma^S of (5.6)
    gamma_L: float  # gamma^L of (5.6)
    mub_S: float  # mu_b^S(1, 1) of (5.6)
    mub_L: float  # mu_b^L(1, 1)
    Gamma_S: float  # (5.18)
    Gamma_L: float  # (5.18)
    mu_h: float  # (5.15)
    mu_u: float  # (5.16)
    mu_phi: float  # (5.17)
    G0: float  # G(phi0), (5.14a)
    dG0: float  # G'(phi0), (5.14b)
    tan_zeta: float
    Fc: float  # 1/|G'(phi0)|, (5.27); inf where G'(phi0) = 0
    material: Material = TABLE1

    @property
    def inv_R(self) -> float:
        """1/R = nu / (u0 sqrt(h0)); exactly 0 for the inviscid model (avoids inf * 0)."""
        return self.nu / (self.u0 * math.sqrt(self.h0))

    @property
    def inviscid(self) -> bool:
        return self.nu == 0.0

    @property
    def time_scale(self) -> float:
        """h0/u0 [s]: a dimensionless rate sigma^ is sigma^ / time_scale in 1/s."""
        return self.h0 / self.u0

    def criticality(self) -> float:
        """F |G0'| - 1: negative below Fc, zero at Fc, positive above (F^2 G0'^2 = (F/Fc)^2)."""
        return self.F * abs(self.dG0) - 1.0

    def with_nu(self, nu: float) -> "BaseState":
        """Same steady state, other viscosity (R changes, nothing else)."""
        return base_state(self.h0, self.phi0, nu, self.material)

    def as_dict(self) -> dict:
        d = asdict(self)
        d.pop("material")
        d["zeta_deg"] = self.material.zeta_deg
        return d


def check_viscosity(nu: float) -> None:
    require(
        isinstance(nu, (int, float)) and math.isfinite(nu) and nu >= 0.0,
        f"nu={nu!r}: the viscosity coefficient must be a finite number >= 0 m^(3/2)/s "
        f"(0 gives the inviscid model)",
    )


def base_state(h0: float, phi0: float, nu: float, material: Material = TABLE1) -> BaseState:
    """Base state for thickness h0 [m], concentration phi0 and viscosity coefficient nu.

    Raises `tiseg.errors.InputError` for h0 <= 0, phi0 outside [0, 1], phi0 <= phi0* (no
    steady uniform flow, (4.8)), nu < 0, or a slope outside the range (3.10) for which the
    segregation-mobility model is built.
    """
    check_thickness(h0)
    check_concentration(phi0)
    check_viscosity(nu)
    m = material
    m.require_finger_range()
    per = froude_per_thickness(phi0, m)  # raises below phi0*
    F = h0 * per
    u0 = F * math.sqrt(m.g * h0 * m.cos_zeta)
    R = math.inf if nu == 0 else u0 * math.sqrt(h0) / nu

    s, l = m.small, m.large
    gS = s.beta * h0 / (s.L * F)
    gL = l.beta * h0 / (l.L * F)
    # mu_b^N(h, u) = mu1 + (mu2 - mu1)/(gamma h^{3/2}/u + 1) at h = u = 1, (5.6)
    mubS = s.mu1 + (s.mu2 - s.mu1) / (gS + 1.0)
    mubL = l.mu1 + (l.mu2 - l.mu1) / (gL + 1.0)
    GamS = gS * (s.mu2 - s.mu1) / (1.0 + gS) ** 2
    GamL = gL * (l.mu2 - l.mu1) / (1.0 + gL) ** 2
    mix = phi0 * GamS + (1.0 - phi0) * GamL
    return BaseState(
        h0=float(h0),
        phi0=float(phi0),
        nu=float(nu),
        u0=u0,
        F=F,
        R=R,
        gamma_S=gS,
        gamma_L=gL,
        mub_S=mubS,
        mub_L=mubL,
        Gamma_S=GamS,
        Gamma_L=GamL,
        mu_h=-1.5 * mix,  # (5.15): d/dh of h^{3/2} gives -3/2
        mu_u=mix,  # (5.16)
        mu_phi=mubS - mubL,  # (5.17)
        G0=float(m.G(phi0)),
        dG0=float(m.dG(phi0)),
        tan_zeta=m.tan_zeta,
        Fc=critical_froude(phi0, m),
        material=m,
    )


def base_state_from_froude(
    F: float, phi0: float, nu: float, material: Material = TABLE1
) -> BaseState:
    """Base state with a prescribed Froude number: h0 = F / (F/h0), F being linear in h0 (4.9)."""
    require(
        isinstance(F, (int, float)) and math.isfinite(F) and F > 0,
        f"F={F!r}: the Froude number must be a positive number",
    )
    check_concentration(phi0)
    material.require_finger_range()
    return base_state(F / froude_per_thickness(phi0, material), phi0, nu, material)


__all__ = ["BaseState", "base_state", "base_state_from_froude", "check_viscosity"]
