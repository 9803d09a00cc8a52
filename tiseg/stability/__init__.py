"""Linear stability of steady uniform flows, section 5 and appendices A, B.

* `base` -- the dimensionless base state (F, R, mu_h, mu_u, mu_phi, G0, G0', ...), 5.1-5.2;
* `dispersion1d` -- the 3x3 matrix (5.21), its cubic (A1)-(A7), sigma_M (5.23), the most
  unstable mode and the viscous cutoff (A.3);
* `dispersion2d` -- the 4x4 problem of appendix B and its quartic (B2)-(B5), corrected;
* `asymptotics` -- the high-wavenumber laws (5.28)-(5.35), (B7), (B8), (B11).
"""

from .base import BaseState, base_state, base_state_from_froude
from .dispersion1d import cutoff, cutoff_analytic, most_unstable, roots, sigma_M

__all__ = [
    "BaseState",
    "base_state",
    "base_state_from_froude",
    "roots",
    "sigma_M",
    "most_unstable",
    "cutoff",
    "cutoff_analytic",
]
