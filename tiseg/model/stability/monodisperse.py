"""Roll waves: linear stability of a monodisperse steady uniform flow (phi fixed).

Without segregation (or with phi0 = 1, where G0 = G(1) = 0 decouples Phi), the normal modes
(h1, u1) = (H, U) exp(sigma t + i k x) of the mass and momentum balances (5.2), (5.3) satisfy
B W = sigma W with B the upper-left 2 x 2 block of the matrix (5.21): the Saint-Venant
equations with the friction law (3.7) and the depth-averaged mu(I) viscosity of Gray &
Edwards (2014). k and sigma are dimensionless in the scalings (5.1).

* Long waves (k -> 0) grow when the kinematic wave, of speed 1 - mu_h / mu_u, outruns the
  downslope gravity wave 1 + 1/F, i.e. for F > F_rw = mu_u / |mu_h| (`threshold_froude`). With
  (3.7), mu_h = -(3/2) mu_u (5.15), (5.16), so F_rw = 2/3 whatever the material: the roll-wave
  threshold of Forterre & Pouliquen (2003).
* The viscous term damps short waves like k^2 / R, so above F_rw a band 0 < k < k_c grows
  and every k > k_c decays (`cutoff`): the high-wavenumber cut-off that Gray & Edwards (2014)
  obtained from the depth-averaged mu(I)-rheology. Without viscosity (R = inf) there is none.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from .base import BaseState
from .dispersion1d import matrix


def bulk_matrix(bs: BaseState, k) -> np.ndarray:
    """B(k): the (H, U) block of (5.21), shape k.shape + (2, 2), complex."""
    return matrix(bs, k)[..., :2, :2]


def bulk_roots(bs: BaseState, k) -> np.ndarray:
    """Both eigenvalues sigma of B(k), shape k.shape + (2,), the larger real part first."""
    lam = np.linalg.eigvals(bulk_matrix(bs, k))
    order = np.argsort(-lam.real, axis=-1)
    return np.take_along_axis(lam, order, axis=-1)


def bulk_growth(bs: BaseState, k) -> np.ndarray:
    """The growth rate max Re sigma of the monodisperse modes at k (dimensionless)."""
    return bulk_roots(bs, k)[..., 0].real


def threshold_froude(bs: BaseState) -> float:
    """F_rw = mu_u / |mu_h|: long waves grow for F > F_rw (2/3 with the law (3.7))."""
    return float(bs.mu_u / abs(bs.mu_h))


def most_unstable(bs: BaseState, hi: float = 1e2) -> tuple[float, float]:
    """(k_M, sigma_M): the wavenumber of the fastest-growing mode and its growth rate."""
    k = np.logspace(-4, np.log10(hi), 400)
    s = bulk_growth(bs, k)
    i = int(np.argmax(s))
    lo, up = k[max(i - 1, 0)], k[min(i + 1, len(k) - 1)]
    res = minimize_scalar(
        lambda x: -bulk_growth(bs, np.array([x]))[0],
        bounds=(lo, up),
        method="bounded",
        options={"xatol": 1e-10},
    )
    return float(res.x), float(-res.fun)


def cutoff(bs: BaseState, hi: float = 1e3) -> float | None:
    """k_c: the growth rate changes sign there, from growth below to decay above; None when
    nothing grows (F <= F_rw) or nothing decays up to ``hi`` (no viscosity)."""
    k_M, s_M = most_unstable(bs)
    if s_M <= 0.0 or bulk_growth(bs, np.array([hi]))[0] >= 0.0:
        return None
    return float(brentq(lambda x: bulk_growth(bs, np.array([x]))[0], k_M, hi, xtol=1e-12))
