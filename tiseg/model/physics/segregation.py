"""Transport functions G(phi) of the large-particle transport equation (2.15), (6.3) as
components: one class per function, one registry line each.

The large-particle flux is h u (phi - G(phi)) (6.3); G comes from the shear profile through
(2.16), G(phi) = phi - int_0^phi f(z) dz, and vanishes at phi = 0 and 1. A transport function
holds everything the solver needs of it:

* ``slots`` and ``values``: its run-time numbers, stored in the operator's parameter field at
  the index the operator gives it (`tiseg.model.physics.param_layout.ParamLayout`);
* ``taichi``: its Taichi functions ``G(e, phi)`` and ``dG(e, phi)``, built for one operator (e: the ensemble member, whose row of the parameter field they read) (so a
  function that is not chosen, or no segregation at all, leaves no code in the kernels);
* ``G_np`` / ``dG_np``: the NumPy twins, written apart from the Taichi functions (and
  ``shear_profile_np``, the profile f of (2.12) or (2.13) that G comes from), used by the reference
  operator, the stability analysis (G(phi0), G'(phi0) of (5.14)) and the run estimate, whose
  step bound takes the segregation wave speed |u (1 - G'(phi))| (5.26) from ``dG_np``.
  Segregation adds no stiff term (it is all in the flux), so it has no stiffness bound for the
  RKC stage count.

The scene's allowed ``material.transport`` values are the keys of `TRANSPORTS`. Every
transport function here has phi - G(phi) non-decreasing on [0, 1] (1 - G' >= 0), so upwinding
phi by the sign of the mass flux upwinds the large-particle flux (``numerics.phi_flux``).
This module imports no Taichi (and nothing of tiseg: `tiseg.model.material` takes its G from
here).
"""

from __future__ import annotations

import numpy as np


class Linear:
    """(2.17), the linear shear profile's G = (1 - alpha) phi (1 - phi), alpha =
    ``material.alpha`` (1/7 throughout the paper, which makes the area under G equal to that
    of (2.18)). Slot: 1 - alpha. 1 - G' = alpha + 2 (1 - alpha) phi lies in [alpha, 2 - alpha]."""

    name = "linear"
    slots = ("alpha1",)

    def values(self, alpha: float) -> list[float]:
        return [1.0 - alpha]

    def G_np(self, phi, alpha: float):
        phi = np.asarray(phi, dtype=float)
        return (1.0 - alpha) * phi * (1.0 - phi)

    def dG_np(self, phi, alpha: float):
        phi = np.asarray(phi, dtype=float)
        return (1.0 - alpha) * (1.0 - 2.0 * phi)

    def shear_profile_np(self, z, alpha: float):
        """f_L(z) = alpha + 2 (1 - alpha) z, (2.12): alpha is the basal slip."""
        return alpha + 2.0 * (1.0 - alpha) * np.asarray(z, dtype=float)

    def taichi(self, ti, par, base: int):
        """(G(phi), dG(phi)) reading 1 - alpha from par[e, base]."""

        @ti.func
        def G(e, phi):
            return par[e, base] * phi * (1.0 - phi)

        @ti.func
        def dG(e, phi):
            return par[e, base] * (1.0 - 2.0 * phi)

        return G, dG


class Bagnold:
    """(2.18), the Bagnold shear profile's G = 2/3 (1 - phi)(1 - (1 - phi)^{3/2}), with
    G' = 5/3 (1 - phi)^{3/2} - 2/3; no run-time numbers. 1 - G' = 5/3 (1 - (1 - phi)^{3/2}) lies
    in [0, 5/3]: pure large grains (phi = 0) do not move relative to the bulk's slowest
    characteristic, and the flux is convex in phi.

    (1 - phi)^{3/2} is complex for phi > 1, which is why the paper takes (2.17) (section 2.3):
    here 1 - phi is clamped at 0 (the solver's phi lies in [0, 1] up to round-off), and the
    power is c sqrt(c), which SPIR-V has in 64 bits too (it has no 64-bit pow)."""

    name = "bagnold"
    slots: tuple[str, ...] = ()

    def values(self, alpha: float) -> list[float]:
        return []

    def G_np(self, phi, alpha: float):
        c = 1.0 - np.clip(np.asarray(phi, dtype=float), 0.0, 1.0)
        return (2.0 / 3.0) * c * (1.0 - c**1.5)

    def dG_np(self, phi, alpha: float):
        c = 1.0 - np.clip(np.asarray(phi, dtype=float), 0.0, 1.0)
        # d/dphi of 2/3 (c - c^{5/2}) with dc/dphi = -1
        return -(2.0 / 3.0) * (1.0 - 2.5 * c**1.5)

    def shear_profile_np(self, z, alpha: float):
        """f_B(z) = 5/3 (1 - (1 - z)^{3/2}), (2.13): no basal slip."""
        return (5.0 / 3.0) * (1.0 - (1.0 - np.asarray(z, dtype=float)) ** 1.5)

    def taichi(self, ti, par, base: int):
        @ti.func
        def G(e, phi):
            c = ti.max(1.0 - phi, 0.0)
            return (2.0 / 3.0) * c * (1.0 - c * ti.sqrt(c))

        @ti.func
        def dG(e, phi):
            c = ti.max(1.0 - phi, 0.0)
            return (5.0 / 3.0) * c * ti.sqrt(c) - 2.0 / 3.0

        return G, dG


TRANSPORTS: dict[str, Linear | Bagnold] = {t.name: t for t in (Linear(), Bagnold())}
