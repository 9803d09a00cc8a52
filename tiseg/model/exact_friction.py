"""Exact solutions of the depth-averaged avalanche equations with Coulomb basal friction
mu = tan(delta) on a plane inclined at zeta, in the slope-aligned coordinates of (6.1)-(6.4)
(gravity g sin(zeta) along the slope, g cos(zeta) normal to it; no viscosity, one species).

Where the velocity keeps one sign the friction is a constant deceleration g cos(zeta)
tan(delta), so gravity and friction together accelerate every material point by

    m = g cos(zeta) (tan(zeta) - tan(delta)),

and the shallow-water solutions of a flat frictionless bed hold in a frame that accelerates
with m (Savage & Hutter 1991; Mangeney, Heinrich & Roche 2000). Three of them:

* `coulomb_dam_break`: an infinite reservoir h0 released from rest onto a dry bed (Mangeney,
  Heinrich & Roche 2000, Pure Appl. Geophys. 157, 1081): Ritter's rarefaction, carried by
  x_s(t) = m t^2 / 2; valid for m > 0 (u > 0 everywhere);
* `sliding_layer`: a uniform layer sliding at u0 on a slope its friction can hold
  (m < 0), which decelerates at |m| and stops exactly at t* = u0 / |m| after u0^2 / (2 |m|),
  and stays (the stopping of a Coulomb block; Savage & Hutter 1989);
* `parabolic_cap`: a finite parabolic cap h = h_c (1 - xi^2) sliding and spreading with a
  linear velocity (the similarity solution of Savage & Hutter 1991), whose two margins, one
  advancing and one receding, move with a finite slope of h; valid while u > 0 everywhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

G = 9.81


def net_acceleration(zeta: float, delta: float, g: float = G) -> float:
    """m = g cos(zeta) (tan(zeta) - tan(delta)) [m/s^2] (angles in radians)."""
    return g * math.cos(zeta) * (math.tan(zeta) - math.tan(delta))


# ---------------------------------------------------------------------- the dam break
def coulomb_dam_break(x, t: float, h0: float, zeta: float, delta: float, x0=0.0, g=G):
    """(h, u) at the points x and time t > 0 of the dam break with Coulomb friction: h0 for
    x < x0 at rest at t = 0, dry beyond. With c0 = sqrt(g cos(zeta) h0), xi = x - x0 - m t^2/2:
    h = h0, u = m t for xi <= -c0 t; h = (2 c0 - xi / t)^2 / (9 g cos(zeta)),
    u = (2/3)(xi / t + c0) + m t in the fan up to the front xi = 2 c0 t; dry beyond."""
    m = net_acceleration(zeta, delta, g)
    if not m > 0:
        raise ValueError("the dam break's closed form needs tan(zeta) > tan(delta)")
    gc = g * math.cos(zeta)
    c0 = math.sqrt(gc * h0)
    xi = (np.asarray(x, dtype=float) - x0 - 0.5 * m * t * t) / t
    fan = (xi > -c0) & (xi < 2 * c0)
    h = np.where(xi <= -c0, h0, np.where(fan, (2 * c0 - xi) ** 2 / (9 * gc), 0.0))
    u = np.where(xi <= -c0, m * t, np.where(fan, (2.0 / 3.0) * (xi + c0) + m * t, 0.0))
    return h, u


def dam_break_contour(theta: float, t: float, h0: float, zeta, delta, x0=0.0, g=G) -> float:
    """Where the dam break's h equals theta h0 (0 < theta < 1) at time t: the fan's point
    x0 + m t^2 / 2 + (2 c0 - 3 sqrt(g cos(zeta) theta h0)) t. theta -> 1 is the tail of
    the rarefaction, theta -> 0 the front (at 2 c0 t ahead of x0 + m t^2 / 2)."""
    gc = g * math.cos(zeta)
    c0 = math.sqrt(gc * h0)
    m = net_acceleration(zeta, delta, g)
    return x0 + 0.5 * m * t * t + (2 * c0 - 3 * math.sqrt(gc * theta * h0)) * t


def dam_break_arrival(xg: float, theta: float, h0: float, zeta, delta, x0=0.0, g=G) -> float:
    """The time at which h first reaches theta h0 at the point xg > x0: the root of
    dam_break_contour(theta, t) = xg, t = (-b + sqrt(b^2 + 2 m d)) / m with
    b = 2 c0 - 3 sqrt(g cos(zeta) theta h0) and d = xg - x0."""
    gc = g * math.cos(zeta)
    b = 2 * math.sqrt(gc * h0) - 3 * math.sqrt(gc * theta * h0)
    m = net_acceleration(zeta, delta, g)
    d = xg - x0
    return (-b + math.sqrt(b * b + 2 * m * d)) / m


# ---------------------------------------------------------------------- a layer that stops
def sliding_layer(t, u0: float, zeta: float, delta: float, g=G):
    """(u, displacement) at times t of a uniform layer sliding downslope at u0 > 0 at t = 0
    under Coulomb friction tan(delta): u = u0 + m t until it stops, then 0 for ever where the
    friction holds it (m < 0); the displacement is the integral of u."""
    m = net_acceleration(zeta, delta, g)
    t = np.asarray(t, dtype=float)
    if m >= 0:  # it never stops
        return u0 + m * t, u0 * t + 0.5 * m * t * t
    ts = u0 / -m
    tc = np.minimum(t, ts)
    return np.where(t < ts, u0 + m * t, 0.0), u0 * tc + 0.5 * m * tc * tc


def stopping_time(u0: float, zeta: float, delta: float, g=G) -> float:
    """u0 / |m|: when a layer sliding at u0 on a slope its friction holds comes to rest."""
    m = net_acceleration(zeta, delta, g)
    if not m < 0:
        raise ValueError("a layer stops only where tan(delta) > tan(zeta)")
    return u0 / -m


# ---------------------------------------------------------------------- the parabolic cap
@dataclass(frozen=True)
class ParabolicCap:
    """The similarity solution of Savage & Hutter (1991) with an isotropic earth pressure
    (K = 1) and Coulomb friction: h = h_c(t) (1 - xi^2), xi = (x - x_c(t)) / a(t), and
    u = x_c'(t) + (a'(t) / a(t)) (x - x_c(t)) for |xi| < 1, dry elsewhere.

    The centre slides with x_c'' = m (from x_c0 at speed u0); the half-width spreads from a0
    at rest as a'' = K / a^2 with K = (3/2) V g cos(zeta), V = (4/3) h_c a the cap's area,
    conserved: from rest, t = sqrt(a0^3 / (2 K)) [sqrt(r (r - 1)) + ln(sqrt(r) + sqrt(r - 1))]
    with r = a / a0, and a' = sqrt(2 K (1 / a0 - 1 / a)). Valid while u > 0 everywhere
    (`valid_until`), so that the friction keeps its sign: u0 > sqrt(2 K / a0) suffices."""

    x_c0: float
    a0: float
    h_c0: float
    u0: float
    zeta: float
    delta: float
    g: float = G

    @property
    def m(self) -> float:
        return net_acceleration(self.zeta, self.delta, self.g)

    @property
    def area(self) -> float:
        return 4.0 / 3.0 * self.h_c0 * self.a0

    @property
    def K(self) -> float:
        return 1.5 * self.area * self.g * math.cos(self.zeta)

    def _time_of(self, r: float) -> float:
        return math.sqrt(self.a0**3 / (2 * self.K)) * (
            math.sqrt(r * (r - 1)) + math.log(math.sqrt(r) + math.sqrt(r - 1))
        )

    def half_width(self, t: float) -> tuple[float, float]:
        """(a, a') at time t >= 0."""
        if t <= 0:
            return self.a0, 0.0
        hi = 2.0
        while self._time_of(hi) < t:
            hi *= 2.0
        r = brentq(lambda s: self._time_of(s) - t, 1.0, hi, xtol=1e-15, rtol=1e-15)
        a = r * self.a0
        return a, math.sqrt(2 * self.K * (1 / self.a0 - 1 / a))

    def valid_until(self, t: float) -> bool:
        """Whether u > 0 everywhere at every time up to t (the rear margin's speed
        x_c' - a' only falls after a' grows: checking t suffices as m >= 0)."""
        _, da = self.half_width(t)
        return self.u0 + min(self.m, 0.0) * t - da > 0

    def __call__(self, x, t: float):
        """(h, u) at the points x and time t."""
        a, da = self.half_width(t)
        xc = self.x_c0 + self.u0 * t + 0.5 * self.m * t * t
        hc = self.h_c0 * self.a0 / a
        s = (np.asarray(x, dtype=float) - xc) / a
        inside = np.abs(s) < 1
        h = np.where(inside, hc * (1 - s * s), 0.0)
        u = np.where(inside, self.u0 + self.m * t + da * s, 0.0)
        return h, u

    def margins(self, t: float) -> tuple[float, float]:
        """(rear, front): x_c -+ a at time t."""
        a, _ = self.half_width(t)
        xc = self.x_c0 + self.u0 * t + 0.5 * self.m * t * t
        return xc - a, xc + a
