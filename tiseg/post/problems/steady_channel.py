"""The steady speed profile across a straight channel between levees: the exact answer of the
``channel`` verification scene (``initial.kind = "channel"``).

A layer of uniform thickness h with a concentration that depends on y alone (phi_channel in
|y - Ly/2| < width/2, phi_levee outside) and v = 0 stays so for ever under (6.1)-(6.3): the
cross-slope pressure gradient is zero, nothing varies downslope, and the large-particle flux
h u (phi - G(phi)) points downslope, so phi(y) is fixed. Only the downslope speed u(y) evolves,
under gravity, the basal friction (6.4) with the concentration-weighted law (3.4), (3.7), and
the viscous stress of (6.2), (6.6), which for u(y) alone reduces to d/dy(nu h^{3/2} (1/2) du/dy).
Its steady state solves the cross-slope boundary-value problem

    (1/2) nu h^{3/2} u'' + g h (sin zeta - cos zeta mu_b(h, |u|, phi(y)) u / max(|u|, u_eps)) = 0,

periodic across Ly. The regularised direction u / max(|u|, u_eps) is the solver's (its
`tiseg.solver.reference.operator` twin is used here), so that coarse levees on a slope below their
zeta_1 come to the same slow creep (u ~ u_eps tan zeta / mu_b) as in the simulation.

By symmetry (levee centre at y = 0, channel centre at y = Ly/2) it is solved on [0, Ly/2] as two
smooth pieces, levee [0, y_c] and channel [y_c, Ly/2] with y_c = (Ly - width)/2, joined by
continuity of u and of the stress at y_c, with scipy's collocation solver ``solve_bvp``. Without
viscosity the profile is the local balance, piecewise constant.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ...solver.numerics.config import config_from_scene
from ...solver.reference import ReferenceOperator


@dataclass(frozen=True)
class ChannelProfile:
    """u(y) of the steady channel; ``u(y)`` evaluates it anywhere in [0, Ly] (periodic)."""

    Ly: float
    width: float
    u_channel: float  # at the channel centre y = Ly/2 [m/s]
    u_levee: float  # at the levee centre y = 0 [m/s]
    _solution: object  # scipy's BVP solution on s in [0, 1], or None (inviscid)

    @property
    def y_contact(self) -> float:
        return 0.5 * (self.Ly - self.width)

    def u(self, y) -> np.ndarray:
        y = np.mod(np.asarray(y, dtype=float), self.Ly)
        r = np.where(y > 0.5 * self.Ly, self.Ly - y, y)  # fold onto [0, Ly/2]
        yc = self.y_contact
        if self._solution is None:
            return np.where(r < yc, self.u_levee, self.u_channel)
        in_levee = r < yc
        s = np.where(in_levee, r / yc, (r - yc) / (0.5 * self.Ly - yc))
        vals = self._solution.sol(np.clip(s, 0.0, 1.0))
        return np.where(in_levee, vals[0], vals[2])

    def cell_averages(self, y_centres, dy: float, points: int = 16) -> np.ndarray:
        """Averages of u over cells [y - dy/2, y + dy/2] (Gauss-Legendre, ``points`` nodes)."""
        xg, wg = np.polynomial.legendre.leggauss(points)
        y = np.asarray(y_centres, dtype=float)[:, None] + 0.5 * dy * xg[None, :]
        return (self.u(y) * wg[None, :]).sum(axis=1) * 0.5


def channel_profile(scene, tol: float = 1e-5) -> ChannelProfile:
    """The steady u(y) of a scene with ``initial.kind = "channel"`` (see the module docstring).

    ``tol``: solve_bvp's residual tolerance. The mesh is refined mostly at the kink of
    max(|u|, u_eps) in any case: at 500 cells/m, tol = 1e-5 and 1e-7 give profiles equal to
    1e-12 relative."""
    from scipy.integrate import solve_bvp

    ini = scene.initial
    if ini.kind != "channel":
        raise InputError(
            f"the steady channel profile needs initial.kind='channel', not {ini.kind!r}"
        )
    cfg = config_from_scene(scene)
    ref = ReferenceOperator(cfg)
    h = float(ini.h)
    Ly, width = scene.domain.Ly, float(ini.width)
    yc = 0.5 * (Ly - width)
    Lc = 0.5 * width
    seg = scene.segregation

    def accel(u, phi):
        """g (sin zeta - cos zeta mu_b u / max(|u|, u_eps)): the source per unit thickness."""
        spd = np.abs(u)
        mu = ref.mu_b(np.full_like(u, h), spd, np.full_like(u, phi if seg else cfg.phi_ref))
        return cfg.g_sin - cfg.g_cos * mu * u / np.maximum(spd, cfg.u_eps)

    def balance(phi):
        """Root of accel(u, phi) = 0 for u >= 0: the local speed without viscosity."""
        from scipy.optimize import brentq

        f = lambda u: float(accel(np.array([u]), phi)[0])  # noqa: E731
        if f(0.0) <= 0.0:
            return 0.0
        hi = 1.0
        while f(hi) > 0.0:
            hi *= 2.0
            if hi > 1e4:
                raise InputError(
                    "no steady channel speed: the friction never balances gravity "
                    f"at phi={phi:g} (the material accelerates without bound)"
                )
        return brentq(f, 0.0, hi, xtol=1e-14, rtol=1e-14)

    u_l = balance(ini.phi_levee)
    u_c = balance(ini.phi_channel)
    nu = scene.acting_nu
    if nu <= 0.0:
        return ChannelProfile(Ly, width, u_c, u_l, None)
    D = 0.5 * nu * h * math.sqrt(h)  # u'' = -(g h / D) accel(u)

    def rhs(s, Y):
        return np.vstack(
            [
                Y[1],
                -(yc * yc) * h / D * accel(Y[0], ini.phi_levee),
                Y[3],
                -(Lc * Lc) * h / D * accel(Y[2], ini.phi_channel),
            ]
        )

    def bc(Ya, Yb):
        # symmetry at both centres; u and the stress D u' continuous at the contact
        return np.array([Ya[1], Yb[3], Yb[0] - Ya[2], Yb[1] / yc - Ya[3] / Lc])

    # initial guess: exponential boundary layers on either side of the contact, of the width
    # over which the viscous stress can turn the speed difference, ell^2 ~ D (u_c - u_l) / (g h)
    du = max(u_c - u_l, 1e-12)
    drive = abs(float(accel(np.array([0.5 * (u_c + u_l)]), ini.phi_levee)[0])) + abs(
        float(accel(np.array([0.5 * (u_c + u_l)]), ini.phi_channel)[0])
    )
    ell = math.sqrt(D * du / (h * max(drive, 1e-12)))
    s = np.linspace(0.0, 1.0, 1001)
    ea = np.exp(-(1.0 - s) * yc / ell)
    eb = np.exp(-s * Lc / ell)
    guess = np.vstack(
        [
            u_l + 0.5 * du * ea,
            0.5 * du * ea * yc / ell,
            u_c - 0.5 * du * eb,
            0.5 * du * eb * Lc / ell,
        ]
    )
    sol = solve_bvp(rhs, bc, s, guess, tol=tol, max_nodes=200_000)
    if not sol.success:
        raise InputError(f"the steady channel profile did not converge: {sol.message}")
    return ChannelProfile(Ly, width, float(sol.sol(1.0)[2]), float(sol.sol(0.0)[0]), sol)
