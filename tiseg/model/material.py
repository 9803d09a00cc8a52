"""Material constants (Table 1) and the closures of sections 2-3.

Pure NumPy functions, vectorised over arrays; the Taichi kernels have ``ti.func`` twins in
`tiseg.model.physics` that are tested against these.

* Pouliquen-Forterre friction of one species, eq. (3.7), written in the division-free form
  ``mu1 + (mu2 - mu1) * L Fr / (beta h + L Fr)`` so that Fr = 0 (material at rest) is regular.
* Concentration-weighted mixture, eq. (3.4).
* Transport functions G: linear shear profile (2.17) for any alpha (default 1/7) and the Bagnold
  profile (2.18), through the components of `tiseg.model.physics.segregation`.
* Monodisperse viscosity coefficient (3.8), defined only for zeta_1 < zeta < zeta_2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from ..errors import InputError, require
from .physics.segregation import TRANSPORTS

GRAVITY = 9.81
DEFAULT_START_GAP_DEG = 1.0  # zeta3 - zeta1 when a species gives no zeta3_deg
DEFAULT_BETA_STAR = 0.136  # Pouliquen & Forterre (2002), as in Edwards & Gray (2015)
DEFAULT_KAPPA = 1e-3  # Pouliquen & Forterre (2002)
# [m/s] a wet cell no faster than this is at rest: the deposit of the peak fields
# (tiseg.run.peaks) and of the run-out analysis (tiseg.post.analysis.deposit)
REST_SPEED = 1e-6


@dataclass(frozen=True)
class Species:
    """Friction parameters of one monodisperse constituent (Table 1)."""

    zeta1_deg: float  # minimum angle of steady flow, mu1 = tan(zeta1)
    zeta2_deg: float  # maximum angle of steady flow, mu2 = tan(zeta2)
    beta: float  # dimensionless constant of (3.7)
    L: float  # length scale of (3.7) [m]
    zeta3_deg: float | None = None  # start angle of a thick layer at rest, mu3 = tan(zeta3),
    # for effects.friction = "pouliquen-extended"; default zeta1_deg + 1 (a choice: Table 1
    # has no start angle, so measure zeta_start(h) and set it)

    @property
    def zeta3(self) -> float:
        """The start angle [degrees]: zeta3_deg, or zeta1_deg + DEFAULT_START_GAP_DEG."""
        return self.zeta1_deg + DEFAULT_START_GAP_DEG if self.zeta3_deg is None else self.zeta3_deg

    @property
    def mu3(self) -> float:
        return math.tan(math.radians(self.zeta3))

    @property
    def mu1(self) -> float:
        return math.tan(math.radians(self.zeta1_deg))

    @property
    def mu2(self) -> float:
        return math.tan(math.radians(self.zeta2_deg))

    def as_dict(self) -> dict:
        """Its keys as a scene writes them (zeta3_deg only when given)."""
        d = dict(zeta1_deg=self.zeta1_deg, zeta2_deg=self.zeta2_deg, beta=self.beta, L=self.L)
        if self.zeta3_deg is not None:
            d["zeta3_deg"] = self.zeta3_deg
        return d

    @property
    def M(self) -> float:
        """M = beta / L [1/m], used in (4.6)-(4.7)."""
        return self.beta / self.L


@dataclass(frozen=True)
class Material:
    """Table 1 of the paper; every constant can be overridden (``Material(zeta_deg=28)`` etc.)."""

    zeta_deg: float = 27.0  # slope angle zeta [degrees]
    small: Species = Species(20.0, 30.0, 0.150, 2.0e-4)
    large: Species = Species(29.0, 40.0, 0.72, 5.0e-4)
    alpha: float = 1.0 / 7.0  # basal slip parameter of the linear shear profile (2.12)
    transport: str = "linear"  # "linear" (2.17) or "bagnold" (2.18)
    g: float = GRAVITY  # gravitational acceleration [m/s^2]
    chi: float = 1.0  # shape factor; the model assumes chi = 1 (section 3)
    beta_star: float = DEFAULT_BETA_STAR  # Froude number below which the extended law
    # ("pouliquen-extended") leaves the dynamic regime (3.7) for the intermediate one;
    # 0.136 of Pouliquen & Forterre (2002), as in Edwards & Gray (2015)
    kappa: float = DEFAULT_KAPPA  # exponent of the extended law's intermediate regime
    # (Fr / beta*)^kappa, 1e-3 as in Pouliquen & Forterre (2002)

    def __post_init__(self):
        require(
            0.0 <= self.zeta_deg < 90.0,
            f"material.zeta_deg={self.zeta_deg!r}: slope angle must lie in [0, 90) degrees",
        )
        require(0.0 <= self.alpha <= 1.0, f"material.alpha={self.alpha!r} must lie in [0, 1]")
        require(
            self.transport in TRANSPORTS,
            f"material.transport={self.transport!r}: choose one of {', '.join(TRANSPORTS)}",
        )
        require(self.g > 0, f"material.g={self.g!r} must be positive")
        require(self.chi == 1.0, "material.chi: only chi = 1 is supported by the model (section 3)")
        require(
            self.beta_star > 0 and math.isfinite(self.beta_star),
            f"material.beta_star={self.beta_star!r} must be a positive Froude number",
        )
        require(
            0.0 < self.kappa <= 1.0,
            f"material.kappa={self.kappa!r} must lie in (0, 1] (Pouliquen & Forterre: 1e-3)",
        )
        for name, sp in (("small", self.small), ("large", self.large)):
            require(
                0.0 <= sp.zeta1_deg < sp.zeta2_deg < 90.0,
                f"material.{name}: need 0 <= zeta1 < zeta2 < 90 degrees, got "
                f"{sp.zeta1_deg}, {sp.zeta2_deg}",
            )
            require(
                sp.beta > 0 and sp.L > 0,
                f"material.{name}: beta and L must be positive, got {sp.beta}, {sp.L}",
            )
            require(
                sp.zeta1_deg <= sp.zeta3 < 90.0,
                f"material.{name}.zeta3_deg={sp.zeta3:g}: the start angle must lie in "
                f"[zeta1_deg={sp.zeta1_deg:g}, 90) degrees (a layer at rest holds at least "
                "as steep a slope as a flow does)",
            )

    @property
    def zeta(self) -> float:
        return math.radians(self.zeta_deg)

    @property
    def tan_zeta(self) -> float:
        return math.tan(self.zeta)

    @property
    def cos_zeta(self) -> float:
        return math.cos(self.zeta)

    def with_(self, **changes) -> "Material":
        return replace(self, **changes)

    def in_finger_range(self) -> bool:
        """The ordering (3.10): zeta1^S < zeta < zeta1^L < zeta2^S < zeta2^L."""
        s, l = self.small, self.large
        return s.zeta1_deg < self.zeta_deg < l.zeta1_deg < s.zeta2_deg < l.zeta2_deg

    def require_finger_range(self) -> None:
        s, l = self.small, self.large
        require(
            self.in_finger_range(),
            f"slope angle zeta={self.zeta_deg} deg is outside the range (3.10) "
            f"zeta1^S={s.zeta1_deg} < zeta < zeta1^L={l.zeta1_deg} < zeta2^S={s.zeta2_deg} "
            f"< zeta2^L={l.zeta2_deg} where the segregation-mobility model applies",
        )

    # ---- transport function -------------------------------------------------------------
    def G(self, phi):
        """Transport function G(phi): (2.17) with this alpha, or (2.18)
        (`tiseg.model.physics.segregation`)."""
        return TRANSPORTS[self.transport].G_np(phi, self.alpha)

    def dG(self, phi):
        """dG/dphi."""
        return TRANSPORTS[self.transport].dG_np(phi, self.alpha)

    # ---- friction -------------------------------------------------------------------------
    def froude(self, h, speed):
        """Local Froude number (3.6)/(6.5): |u| / sqrt(g h cos zeta)."""
        h = np.asarray(h, dtype=float)
        return np.asarray(speed, dtype=float) / np.sqrt(self.g * h * self.cos_zeta)

    def mu_small(self, h, Fr):
        return mu_pouliquen(h, Fr, self.small)

    def mu_large(self, h, Fr):
        return mu_pouliquen(h, Fr, self.large)

    def mu_mixture(self, h, Fr, phi):
        """Concentration-weighted basal friction (3.4)."""
        phi = np.asarray(phi, dtype=float)
        return phi * self.mu_small(h, Fr) + (1.0 - phi) * self.mu_large(h, Fr)

    def nu(self, species: str) -> float:
        """Monodisperse viscosity coefficient nu^N of (3.8) [m^(3/2)/s]."""
        sp = {"small": self.small, "S": self.small, "large": self.large, "L": self.large}.get(
            species
        )
        require(sp is not None, f"species={species!r}: choose 'small' or 'large'")
        return nu_monodisperse(self.zeta_deg, sp, self.g)

    def as_dict(self) -> dict:
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            out[f.name] = v.as_dict() if isinstance(v, Species) else v
        return out


TABLE1 = Material()


def mu_pouliquen(h, Fr, sp: Species):
    """Pouliquen-Forterre friction of one species, eq. (3.7).

    mu = mu1 + (mu2 - mu1) / (beta h / (L Fr) + 1) = mu1 + (mu2 - mu1) L Fr / (beta h + L Fr).
    """
    return pouliquen(h, Fr, sp.mu1, sp.mu2, sp.beta, sp.L)


def pouliquen(h, Fr, mu1, mu2, beta, L):
    """(3.7) from its four constants, division-free at Fr = 0 (arrays or floats)."""
    h = np.asarray(h, dtype=float)
    Fr = np.asarray(Fr, dtype=float)
    x = L * Fr
    return mu1 + (mu2 - mu1) * x / (beta * h + x)


def nu_monodisperse(zeta_deg: float, sp: Species, g: float = GRAVITY) -> float:
    """nu^N of (3.8): 2 L sqrt(g) / (9 beta) * sin(zeta)/sqrt(cos(zeta)) * (mu2 - tan z)/(tan z - mu1).

    Defined only for zeta1^N < zeta < zeta2^N; outside, the coefficient is negative and the
    monodisperse depth-averaged theory is ill posed, so this raises `InputError`.
    """
    if not (sp.zeta1_deg < zeta_deg < sp.zeta2_deg):
        raise InputError(
            f"viscosity (3.8) is undefined at zeta={zeta_deg} deg: it needs "
            f"zeta1={sp.zeta1_deg} < zeta < zeta2={sp.zeta2_deg} deg (outside, nu would be "
            f"negative and the theory ill posed); give a constant nu instead"
        )
    z = math.radians(zeta_deg)
    t = math.tan(z)
    return (
        2.0
        * sp.L
        * math.sqrt(g)
        / (9.0 * sp.beta)
        * math.sin(z)
        / math.sqrt(math.cos(z))
        * (sp.mu2 - t)
        / (t - sp.mu1)
    )
