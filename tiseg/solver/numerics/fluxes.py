"""Numerical fluxes of the finite-volume scheme as components (``numerics.flux``), and the
modifier of the h phi component (``numerics.phi_flux``): one class each, one registry line each.

A numerical flux H(w_l, w_r) turns the two edge states of a face (primitives w = (h, u[, v][,
phi]), reconstructed by `reconstruction`) into the flux through it. It holds, in the shape
of the physics laws (`tiseg.model.physics.friction`):

* ``taichi(ti, phys)``: its Taichi function ``flux(wl, wr, d, g)`` for one operator, built on
  the pointwise physics `tiseg.model.physics.pointwise.Physics` (physical flux, conserved
  state, wave speeds along d; g the face's gravity, `tiseg.solver.numerics.gravity`); the
  operator composes it with ``ti.static`` at construction, so a flux that is not chosen
  leaves no code in the kernels;
* ``flux_np(ref, wl, wr, d, g)``: its NumPy twin on arrays of edge states, built on the reference
  operator's pointwise physics (`tiseg.solver.reference.operator.ReferenceOperator`), written
  apart from the Taichi function with the same operations in the same order;
* ``slots``: the run-time numbers it reads (none: the wave speeds come from the physics).

A phi-flux modifier rewrites the h phi component of a face's flux after the numerical flux; it
is only applied with segregation. `FLUXES` and `PHI_FLUXES` are the registries the
scene's allowed values come from (`tiseg.solver.numerics.config`). This module imports no Taichi.
"""

import numpy as np


class KurganovTadmor:
    """Kurganov & Tadmor (2000): H = (f_l + f_r)/2 - a/2 (q_r - q_l), a the larger local speed
    max(|u_n| + c, |u_n (1 - G'(phi))|) of the two edge states (segregation wave speed (5.26)
    included)."""

    name = "kt"
    slots: tuple[str, ...] = ()

    def taichi(self, ti, phys):
        @ti.func
        def flux(e, wl, wr, d: ti.template(), g):
            fl = phys.flux(e, wl, d, g)
            fr = phys.flux(e, wr, d, g)
            dq = phys.conserved(wr) - phys.conserved(wl)
            F = 0.5 * (fl + fr)
            a = ti.max(phys.speed(e, wl, d, g), phys.speed(e, wr, d, g))
            F -= 0.5 * a * dq
            return F

        return flux

    def flux_np(self, ref, wl, wr, d: int, g=None):
        ql, qr = ref.conserved(wl), ref.conserved(wr)
        fl, fr = ref.flux(wl, d, g), ref.flux(wr, d, g)
        a = np.maximum(ref.speed(wl, d, g), ref.speed(wr, d, g))
        return 0.5 * (fl + fr) - 0.5 * a * (qr - ql)


class CentralUpwind:
    """Kurganov, Noelle & Petrova (2001): H = (a+ f_l - a- f_r)/(a+ - a-) + a+ a-/(a+ - a-)
    (q_r - q_l), with the one-sided speeds a+ = max(hi_l, hi_r, 0), a- = min(lo_l, lo_r, 0) of
    the characteristic speed ranges u_n -+ c widened by u_n (1 - G'); H = (f_l + f_r)/2 where
    a+ = a- = 0. It equals KT where the waves run both ways at equal speed and dissipates less
    where the flow is one-sided (HLL with these speed estimates)."""

    name = "central-upwind"
    slots: tuple[str, ...] = ()

    def taichi(self, ti, phys):
        @ti.func
        def flux(e, wl, wr, d: ti.template(), g):
            fl = phys.flux(e, wl, d, g)
            fr = phys.flux(e, wr, d, g)
            dq = phys.conserved(wr) - phys.conserved(wl)
            F = 0.5 * (fl + fr)
            sl = phys.speed_range(e, wl, d, g)
            sr = phys.speed_range(e, wr, d, g)
            ap = ti.max(ti.max(sl[1], sr[1]), 0.0)
            am = ti.min(ti.min(sl[0], sr[0]), 0.0)
            den = ap - am
            if den > 0:
                inv = 1.0 / den
                F = (ap * fl - am * fr) * inv + (ap * am * inv) * dq
            return F

        return flux

    def flux_np(self, ref, wl, wr, d: int, g=None):
        ql, qr = ref.conserved(wl), ref.conserved(wr)
        fl, fr = ref.flux(wl, d, g), ref.flux(wr, d, g)
        lo_l, hi_l = ref.speed_range(wl, d, g)
        lo_r, hi_r = ref.speed_range(wr, d, g)
        ap = np.maximum(np.maximum(hi_l, hi_r), 0.0)
        am = np.minimum(np.minimum(lo_l, lo_r), 0.0)
        den = ap - am
        safe = np.where(den > 0, den, 1.0)
        return np.where(
            den > 0, (ap * fl - am * fr) / safe + ap * am / safe * (qr - ql), 0.5 * (fl + fr)
        )


class Rusanov:
    """Rusanov (1961), the local Lax-Friedrichs flux: H = (f_l + f_r)/2 - a/2 (q_r - q_l), a the
    spectral radius of the flux Jacobian along d, max(|u_n| + c, |u_n (1 - G'(phi))|) (c =
    sqrt(g cos(zeta) h), the segregation wave speed (5.26) with segregation), the larger of the
    two edge states'. The most dissipative of the local-speed fluxes, and the simplest: a
    first-order scheme with it is monotone under the CFL condition. (The Kurganov-Tadmor
    scheme is this flux applied to reconstructed edge states, so "kt" gives the same numbers;
    this class is the worked example of adding a flux: one class, its twin, a registry line.)"""

    name = "rusanov"
    slots: tuple[str, ...] = ()

    def taichi(self, ti, phys):
        @ti.func
        def flux(e, wl, wr, d: ti.template(), g):
            a = ti.max(phys.speed(e, wl, d, g), phys.speed(e, wr, d, g))
            F = 0.5 * (phys.flux(e, wl, d, g) + phys.flux(e, wr, d, g))
            F -= 0.5 * a * (phys.conserved(wr) - phys.conserved(wl))
            return F

        return flux

    def flux_np(self, ref, wl, wr, d: int, g=None):
        a = np.maximum(ref.speed(wl, d, g), ref.speed(wr, d, g))
        dq = ref.conserved(wr) - ref.conserved(wl)
        return 0.5 * (ref.flux(wl, d, g) + ref.flux(wr, d, g)) - 0.5 * a * dq


class CentralPhi:
    """``phi_flux = "central"``: the h phi component stays that of the numerical flux."""

    name = "central"
    slots: tuple[str, ...] = ()

    def taichi(self, ti, phys, lay):
        return None  # nothing to apply: the operator then compiles no modifier

    def modify_np(self, ref, H, wl, wr):
        return H


class UpwindPhi:
    """``phi_flux = "upwind"``: the h phi component becomes F_h (phi - G(phi)), F_h the mass
    component of the numerical flux and phi that of the edge state upwind of F_h (Larrouturou
    1991, J. Comput. Phys. 95, 59): where no mass crosses a face, no phi crosses it, so a
    contact between fine and coarse material along the flow stays sharp, and phi stays in
    [0, 1] (phi - G(phi) is non-decreasing for every transport function,
    `tiseg.model.physics.segregation`)."""

    name = "upwind"
    slots: tuple[str, ...] = ()

    def taichi(self, ti, phys, lay):
        P = lay.HPHI

        @ti.func
        def modify(e, F, wl, wr):
            out = F
            p = ti.select(F[0] >= 0.0, wl[P], wr[P])
            out[P] = F[0] * phys.transported(e, p)
            return out

        return modify

    def modify_np(self, ref, H, wl, wr):
        P = ref.lay.HPHI
        p = np.where(H[ref.lay.H] >= 0.0, wl[P], wr[P])
        H[P] = H[ref.lay.H] * (p - ref.G(p))
        return H


FLUXES: dict[str, KurganovTadmor | CentralUpwind | Rusanov] = {
    f.name: f for f in (KurganovTadmor(), CentralUpwind(), Rusanov())
}
PHI_FLUXES: dict[str, CentralPhi | UpwindPhi] = {f.name: f for f in (CentralPhi(), UpwindPhi())}
