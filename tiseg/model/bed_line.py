"""The bed line of a run-out: a straight at the inclination zeta1, a bend of constant curvature
and a straight at zeta2, parametrised by its arc length s (Savage & Hutter 1991, Acta Mech. 86,
201; Gray, Wieland & Hutter 1999, Proc. R. Soc. A 455, 1841).

On the bend x_b <= s <= x_b + L the inclination changes linearly, zeta(s) = zeta1 - kappa
(s - x_b), with the curvature kappa = -d zeta / ds = (zeta1 - zeta2) / L, positive where the
bed levels out (concave). The solver's reference surface (``[terrain.runout]``,
tiseg.solver.numerics.gravity) and the point-mass run-out (tiseg.model.exact_runout) both
follow it; `gravity_on` gives the gravity it sets along and normal to the bed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


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


def gravity_on(line: BedLine, g: float, s) -> np.ndarray:
    """(g sin zeta, g cos zeta, kappa) at the arc lengths s, shape s.shape + (3,): the
    gravity along the bed line, normal to it, and its curvature (zero on the straights,
    also at the bend's two ends)."""
    z = line.inclination(s)
    return np.stack([g * np.sin(z), g * np.cos(z), line.curvature(s)], axis=-1)


def gravity_columns(line: BedLine, g: float, dx: float, gx: int, NX: int):
    """The gravity of `gravity_on` on a grid's x columns, ghost columns included: (cells,
    faces), each (NX, 3); cells[i] at the centre of column i, faces[i] on the face between
    columns i and i + 1. Column gx is the first interior one, whose low face lies at s = 0."""
    i = np.arange(NX, dtype=float) - gx
    return gravity_on(line, g, (i + 0.5) * dx), gravity_on(line, g, (i + 1.0) * dx)
