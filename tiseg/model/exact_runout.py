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

G = 9.81


def _half_sinc(k: float, d):
    """sin(k d / 2) / k, -> d / 2 as k -> 0."""
    return np.sin(0.5 * k * d) / k if k != 0 else 0.5 * np.asarray(d, dtype=float)


@dataclass(frozen=True)
class BedLine:
    """A straight at zeta1 [rad], a constant-curvature bend over x_b <= s <= x_b + L [m] and a
    straight at zeta2 [rad]; |zeta| < pi/2 everywhere (zeta > 0 descends along +s)."""

    zeta1: float
    zeta2: float
    x_b: float
    L: float = 0.0

    def __post_init__(self):
        if not (abs(self.zeta1) < 0.5 * math.pi and abs(self.zeta2) < 0.5 * math.pi):
            raise ValueError("the inclinations must lie in (-pi/2, pi/2)")
        if self.L < 0:
            raise ValueError(f"the bend's length must be >= 0, got L = {self.L!r}")

    @property
    def kappa(self) -> float:
        """(zeta1 - zeta2) / L [1/m] in the bend (0 for a kink, L = 0)."""
        return (self.zeta1 - self.zeta2) / self.L if self.L > 0 else 0.0

    def inclination(self, s):
        """zeta(s) [rad]."""
        s = np.asarray(s, dtype=float)
        d = np.clip(s - self.x_b, 0.0, self.L)
        z = np.where(s < self.x_b, self.zeta1, self.zeta1 - self.kappa * d)
        return np.where(s > self.x_b + self.L, self.zeta2, z)

    def curvature(self, s):
        """kappa(s) = -d zeta / ds [1/m]: kappa inside the bend, 0 on the straights."""
        s = np.asarray(s, dtype=float)
        return np.where((s > self.x_b) & (s < self.x_b + self.L), self.kappa, 0.0)

    def coordinates(self, s):
        """(X(s), Z(s)) [m]: horizontal distance and height (Z up) from the point s = 0."""
        s = np.asarray(s, dtype=float)
        k, z1 = self.kappa, self.zeta1
        xb, xe = self.x_b, self.x_b + self.L
        d = np.clip(s - xb, 0.0, self.L)
        mid = z1 - 0.5 * k * d  # (zeta1 + zeta(s)) / 2 in the bend
        sh = _half_sinc(k, d)
        xbend, zbend = 2 * np.cos(mid) * sh, -2 * np.sin(mid) * sh
        up = np.minimum(s, xb)  # the part on the first straight
        down = np.maximum(s - xe, 0.0)  # on the second
        X = up * math.cos(z1) + xbend + down * math.cos(self.zeta2)
        Z = -up * math.sin(z1) + zbend - down * math.sin(self.zeta2)
        return X, Z

    def travel_angle(self, s0: float, s1: float) -> float:
        """The travel angle alpha [rad] between the arc lengths s0 < s1: tan(alpha) = drop /
        horizontal distance = (Z(s0) - Z(s1)) / (X(s1) - X(s0)) (Heim's Fahrboschung)."""
        (x0, z0), (x1, z1) = self.coordinates(s0), self.coordinates(s1)
        return math.atan2(float(z0 - z1), float(x1 - x0))


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
