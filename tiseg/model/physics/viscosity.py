"""The depth-averaged mu(I) viscosity of (6.2), (6.6) as a component.

Gray & Edwards (2014) and Baker, Barker & Gray (2016) give the depth-averaged stress
nu h^{3/2} D, D = (grad u + grad u^T) / 2 (6.6), whose divergence enters the momentum balance
(6.2); nu [m^{3/2}/s] is ``flow.nu`` (0.01 in section 6). ``effects.viscosity = false`` (or
``flow.nu = 0``) switches the component off: no slot, no kernel code (``ti.static``).

The component holds what the solver needs of it:

* ``slots`` / ``values``: its one run-time number, nu, stored in the operator's parameter field
  at the index the operator gives it (`tiseg.model.physics.param_layout.ParamLayout`);
* ``taichi``: its Taichi functions, the face coefficient ``face_K(e, h_a, h_b)`` (e: the ensemble member, whose row of the parameter field it reads), the normal and
  shear stresses a face carries and the cell's Gershgorin bound ``cell_stiffness``; they take
  values, never fields (the operator reads the stencil);
* ``face_K_np``: the NumPy twin of the face coefficient, used by the reference operator;
* ``stiffness_uniform``: the same Gershgorin bound for uniform h, which the run estimate uses
  for RKC's stage count (the run computes it cell by cell with ``cell_stiffness``).

Discretisation (the same in the reference operator): the face coefficient is the harmonic mean
K = 2 K_a K_b / (K_a + K_b) of K = nu h^{3/2} of the two cells, zero if either is thinner than
h_min (so no stress reaches a dry cell); normal stress K du/dn, shear stress
K/2 (dv/dn + du/dt) with the tangential derivative averaged over the four cells around the face.
"""

from __future__ import annotations

import math

import numpy as np


class MuIViscosity:
    """nu h^{3/2} D, (6.2) with (6.6); slot: nu."""

    name = "mu-i"
    slots = ("nu",)

    def values(self, nu: float) -> list[float]:
        return [nu]

    def face_K_np(self, ha, hb, nu: float, h_min: float):
        """Harmonic mean of nu h^{3/2} over a face between cells of thickness ha and hb; zero
        if either is thinner than h_min."""
        Ka = nu * ha * np.sqrt(ha)
        Kb = nu * hb * np.sqrt(hb)
        s = Ka + Kb
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.where(s > 0, 2.0 * Ka * Kb / np.where(s > 0, s, 1.0), 0.0)
        return np.where((ha >= h_min) & (hb >= h_min), k, 0.0)

    def stiffness_uniform(self, nu: float, h: float, dx: float, dy: float, is_1d: bool) -> float:
        """The Gershgorin bound of ``cell_stiffness`` for uniform thickness h [1/s]: each face
        has K = nu h^{3/2}, so a direction's sum over its two faces of K (1/h + 1/h) is
        4 nu h^{1/2}."""
        s = 4.0 * nu * math.sqrt(max(h, 0.0))
        if is_1d:
            return s / dx**2
        return max(s / dx**2 + 0.5 * s / dy**2, 0.5 * s / dx**2 + s / dy**2) + 0.125 * 2 * s / (
            dx * dy
        )

    def taichi(self, ti, par, base: int, h_min_slot: int, two_d: bool):
        """(face_K, normal_stress, shear_stress, cell_stiffness) reading nu from par[e, base] and
        h_min from par[e, h_min_slot]; ``two_d``: the cell's bound takes in the y faces and the
        mixed derivatives."""

        @ti.func
        def face_K(e, ha, hb):
            hmin = par[e, h_min_slot]
            nu = par[e, base]
            ka = nu * ha * ti.sqrt(ha)
            kb = nu * hb * ti.sqrt(hb)
            k = 0.0 * ha
            if ha >= hmin and hb >= hmin and ka + kb > 0:
                k = 2.0 * ka * kb / (ka + kb)
            return k

        @ti.func
        def normal_stress(e, K, dn, inv_d):
            """K du_n/dn on a face: dn the jump of the normal velocity across it, inv_d 1/spacing."""
            return K * dn * inv_d

        @ti.func
        def shear_stress(e, K, dt, inv_d, cross):
            """K/2 (du_t/dn + du_n/dt) on a face: dt the jump of the tangential velocity across
            it, cross the tangential derivative of the normal velocity there."""
            return 0.5 * K * (dt * inv_d + cross)

        @ti.func
        def cell_stiffness(e, h, hp, hm, hn, hs, idx, idy):
            """Gershgorin bound of the viscous Jacobian's rows of a cell of thickness h >= h_min
            with x neighbours hp, hm and y neighbours hn, hs (read only in 2D) [1/s]. Each face adds
            K (1/h + 1/h_neighbour) / d^2 to the normal momentum's row sum and half of that to
            the tangential one's; the mixed derivatives couple u to 8 values of v with weights
            K / (8 dx dy) each per face pair: K / (h dx dy) for uniform h."""
            hmin = par[e, h_min_slot]
            inv = 1.0 / h
            sxs = face_K(e, h, hp) * (inv + 1.0 / ti.max(hp, hmin)) + face_K(e, h, hm) * (
                inv + 1.0 / ti.max(hm, hmin)
            )
            rho = sxs * (idx * idx)
            if ti.static(two_d):
                sys = face_K(e, h, hn) * (inv + 1.0 / ti.max(hn, hmin)) + face_K(e, h, hs) * (
                    inv + 1.0 / ti.max(hs, hmin)
                )
                cross = 0.125 * (sxs + sys) * (idx * idy)
                rho = (
                    ti.max(
                        sxs * (idx * idx) + 0.5 * sys * (idy * idy),
                        0.5 * sxs * (idx * idx) + sys * (idy * idy),
                    )
                    + cross
                )
            return rho

        return face_K, normal_stress, shear_stress, cell_stiffness


VISCOSITY = MuIViscosity()
