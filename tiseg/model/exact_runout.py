"""The point-mass (centre-of-mass) run-out of a Coulomb block down a bed line that bends from
the inclination zeta1 to zeta2 (Savage & Hutter 1991, Acta Mech. 86, 201; Gray, Wieland &
Hutter 1999, Proc. R. Soc. A 455, 1841; Heim 1932, Bergsturz und Menschenleben).

The bed line is parametrised by its arc length s: a straight at zeta1 for s < x_b, a
constant-curvature arc over x_b <= s <= x_b + L on which the inclination changes linearly,
zeta(s) = zeta1 - kappa (s - x_b), and a straight at zeta2 beyond. The curvature is

    kappa = -d zeta / ds = (zeta1 - zeta2) / L,

positive where the bed levels out (concave, zeta2 < zeta1): a mass sliding along it at speed u
needs the centripetal acceleration kappa u^2 from the bed, which adds to the normal load.
A block moving along s with velocity u obeys

    ds/dt = u,    du/dt = g sin(zeta) - sign(u) mu (g cos(zeta) + kappa u^2),        (1)

while the normal load g cos(zeta) + kappa u^2 stays positive (a convex bend can lift the
block off: ValueError). Where u reaches 0 it stays at rest if the static friction holds,
|tan(zeta)| <= mu, and otherwise slides back. With `curvature=False` the kappa u^2 term is
dropped (the classical sliding block): the work of the friction is then mu g times the
horizontal distance, so a block released from rest stops where the drop over the horizontal
distance is exactly mu: the travel angle (Fahrboschung, Heim 1932) is atan(mu) for any bed.
The curvature term adds dissipation in a concave bend and shortens the run-out (a steeper
travel angle).

A sudden bend (L = 0) is a kink at x_b. Without the curvature term u is continuous across it;
with it, the limit L -> 0 of (1), d ln|u| / ds = -mu kappa, gives |u| -> |u| exp(-mu (zeta1 -
zeta2)) at a concave kink, and a convex kink launches a moving block (ValueError).

The bed's Cartesian coordinates (X along the horizontal, Z upwards, X = Z = 0 at s = 0) are
X = int cos(zeta) ds, Z = -int sin(zeta) ds, in closed form on each piece.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from .bed_line import BedLine

__all__ = ["BedLine", "Slide", "slide"]

G = 9.81


@dataclass(frozen=True)
class Slide:
    """A block's trajectory: times t [s], positions s [m] and velocities u [m/s] at the
    integrator's steps; `stopped` and where and when (s_stop, t_stop; NaN if not)."""

    t: np.ndarray
    s: np.ndarray
    u: np.ndarray
    stopped: bool
    s_stop: float
    t_stop: float


def _holds(bed: BedLine, s: float, mu: float) -> bool:
    return abs(math.tan(float(bed.inclination(s)))) <= mu


def slide(bed: BedLine, mu: float, s0=0.0, u0=0.0, t_max=1000.0, g=G, curvature=True,
          rtol=1e-12, atol=1e-12) -> Slide:  # fmt: skip
    """Integrate (1) with scipy's solve_ivp (DOP853) from s0 [m], u0 [m/s] at t = 0 until the
    block stops for good (u = 0 where |tan(zeta)| <= mu) or t_max [s]; mu >= 0 is the Coulomb
    coefficient and `curvature` keeps the kappa u^2 term. The pieces of the bed are integrated
    separately (the right-hand side jumps at x_b and x_b + L). ValueError if the block leaves
    the bed (negative normal load)."""
    if mu < 0:
        raise ValueError(f"the friction coefficient must be >= 0, got mu = {mu!r}")
    edges = [bed.x_b] + ([bed.x_b + bed.L] if bed.L > 0 else [])
    ts, ss, us = [np.array([0.0])], [np.array([float(s0)])], [np.array([float(u0)])]
    t, s, u = 0.0, float(s0), float(u0)
    for _ in range(10000):
        if u == 0:
            if _holds(bed, s, mu):
                return Slide(*(np.concatenate(a) for a in (ts, ss, us)), True, s, t)
            direction = 1.0 if float(bed.inclination(s)) > 0 else -1.0
        else:
            direction = math.copysign(1.0, u)
        ahead = [e for e in edges if (e > s if direction > 0 else e < s)]
        edge = (min(ahead) if direction > 0 else max(ahead)) if ahead else None
        # the piece being crossed: its curvature is constant
        k = float(bed.curvature(s + direction * 1e-9 * max(1.0, abs(s)))) if curvature else 0.0

        if g * math.cos(float(bed.inclination(s))) + k * u * u < 0:
            raise ValueError(f"the block leaves the bed at s = {s:.6g} m (convex bend too fast)")

        def rhs(_t, y, k=k, direction=direction):
            z = float(bed.inclination(y[0]))
            return [y[1], g * math.sin(z) - direction * mu * (g * math.cos(z) + k * y[1] ** 2)]

        def stop(_t, y):
            return y[1]

        stop.terminal, stop.direction = True, -direction

        def lift(_t, y, k=k):
            return g * math.cos(float(bed.inclination(y[0]))) + k * y[1] ** 2

        lift.terminal, lift.direction = True, -1
        events = [stop, lift]
        if edge is not None:
            cross = lambda _t, y, e=edge: y[0] - e
            cross.terminal, cross.direction = True, direction
            events.append(cross)
        sol = solve_ivp(rhs, (t, t_max), [s, u], method="DOP853", events=events, rtol=rtol,
                        atol=atol)  # fmt: skip
        ts.append(sol.t[1:])
        ss.append(sol.y[0, 1:])
        us.append(sol.y[1, 1:])
        t, s, u = float(sol.t[-1]), float(sol.y[0, -1]), float(sol.y[1, -1])
        if sol.status != 1:  # t_max reached (or a solver failure)
            if sol.status < 0:
                raise RuntimeError(f"solve_ivp failed: {sol.message}")
            return Slide(*(np.concatenate(a) for a in (ts, ss, us)), False, math.nan, math.nan)
        if sol.t_events[0].size:  # u = 0
            u = 0.0
            us[-1][-1] = 0.0
        elif sol.t_events[1].size:
            raise ValueError(f"the block leaves the bed at s = {s:.6g} m (convex bend too fast)")
        else:  # crossing an edge of the bend
            s = edge
            ss[-1][-1] = s
            if bed.L == 0 and curvature and u != 0:
                if bed.zeta2 > bed.zeta1:
                    raise ValueError("a convex kink (zeta2 > zeta1) launches a moving block")
                u *= math.exp(-mu * (bed.zeta1 - bed.zeta2))
                ts.append(np.array([t]))
                ss.append(np.array([s]))
                us.append(np.array([u]))
    raise RuntimeError("the block reversed more than 10000 times without settling")
