"""The oblique jump (shock) at a wedge in a shallow supercritical stream: the shallow-water
analogue of the oblique shock of gas dynamics, which granular avalanches obey (Gray & Cui 2007,
J. Fluid Mech. 579, 113; Hakonardottir & Hogg 2005, Phys. Fluids 17, 077101; the hydraulic
theory is Ippen 1951, Trans. ASCE 116, 268, and Chow 1959, Open-Channel Hydraulics, McGraw-Hill;
the gas-dynamics analogy, with gamma = 2, Gilmore, Plesset & Crossley 1950, J. Appl. Phys. 21,
243).

A uniform stream of depth h_1 and speed V_1, Froude number F = V_1 / sqrt(g' h_1) with
g' = g cos(zeta) on a plane inclined at zeta (where the along-slope gravity is balanced by the
basal friction, Gray & Cui's non-accelerative slope), meets a wall turned into it by the angle
theta. A straight jump at the angle beta to the oncoming stream turns the flow parallel to the
wall. Across it the tangential velocity is continuous, and mass and normal momentum give the
normal hydraulic jump at the normal Froude number F_n = F sin(beta):

    h_2 / h_1 = R(F_n) = (sqrt(1 + 8 F_n^2) - 1) / 2,                                (1)
    tan(beta - theta) / tan(beta) = h_1 / h_2,                                      (2)

so theta(beta) = beta - atan(tan(beta) / R(F sin(beta))). For F > 1, theta rises from 0 at the
Mach angle beta = asin(1 / F) (R = 1, an infinitesimal wave) to a maximum theta_max(F) at
beta_* and falls back to 0 at beta = pi/2 (the normal jump). A wedge theta < theta_max carries
two attached jumps: the weak one (beta < beta_*, usually seen, its downstream flow mostly
supercritical) and the strong one (beta > beta_*, downstream subcritical, set by the downstream
conditions; Gray & Cui 2007 triggered both). For theta > theta_max the jump detaches from the
tip (a bow jump). theta_max increases with F and tends to pi/2 as F -> infinity, where (2)
gives beta - theta ~ 1 / (sqrt(2) F cos(beta)): unlike gas dynamics (gamma = 1.4: at most
45.6 degrees) a fast enough granular stream keeps the jump attached at almost any wedge.
The detachment Froude number F_d(theta) inverts theta_max(F). For small theta the weak jump
is Ippen's small wave: beta - asin(1/F) ~ 3 F^2 theta / (4 (F^2 - 1)) (the weak oblique shock
with gamma = 2) and h_2 / h_1 - 1 ~ F^2 theta / sqrt(F^2 - 1).

Downstream: V_2 = V_1 cos(beta) / cos(beta - theta), F_2 = F cos(beta) / (cos(beta - theta)
sqrt(R)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy.optimize import brentq

G = 9.81
_EPS = 4 * 2.0**-52


def jump_depth_ratio(fn: float) -> float:
    """h_2 / h_1 of a normal hydraulic jump at the normal Froude number fn (1) (Belanger)."""
    return 0.5 * (math.sqrt(1.0 + 8.0 * fn * fn) - 1.0)


def stagnation_depth_ratio(F: float) -> float:
    """h_s / h_1 at the stagnation point of a blunt obstacle behind a detached (bow) jump in a
    stream of Froude number F > 1: on the symmetry line the jump is normal (h_2 = R h_1,
    u_2 = u_1 / R by (1)), and behind it the steady flow slows smoothly to rest along that
    streamline, so Bernoulli's h + u^2 / (2 g') carries h_2 + u_2^2 / (2 g') to the obstacle:
    h_s / h_1 = R + F^2 / (2 R^2). Where the along-slope gravity is balanced by a Coulomb
    friction, the two still cancel on the symmetry line (the flow there is along +x), so the
    same holds."""
    _check_froude(F)
    r = jump_depth_ratio(F)
    return r + F * F / (2.0 * r * r)


def mach_angle(F: float) -> float:
    """asin(1 / F) [rad]: the angle of an infinitesimal standing wave (F > 1)."""
    _check_froude(F)
    return math.asin(1.0 / F)


def deflection_angle(F: float, beta: float) -> float:
    """theta(beta) [rad] = beta - atan(tan(beta) / R(F sin(beta))), from (1)-(2); 0 at the Mach
    angle and at beta = pi/2."""
    if beta >= 0.5 * math.pi:
        return 0.0
    r = jump_depth_ratio(F * math.sin(beta))
    return beta - math.atan(math.tan(beta) / r)


def _dtheta_dbeta(F: float, beta: float) -> float:
    """d theta / d beta, with y = tan(beta) / R: 1 - y' / (1 + y^2) and
    R' = 4 F^2 sin(beta) cos(beta) / sqrt(1 + 8 F^2 sin^2(beta))."""
    s, c = math.sin(beta), math.cos(beta)
    root = math.sqrt(1.0 + 8.0 * F * F * s * s)
    r = 0.5 * (root - 1.0)
    dr = 4.0 * F * F * s * c / root
    y = s / (c * r)
    dy = (r / (c * c) - (s / c) * dr) / (r * r)
    return 1.0 - dy / (1.0 + y * y)


def _check_froude(F: float) -> None:
    if not F > 1.0:
        raise ValueError(f"an attached jump needs a supercritical stream, F > 1 (got F = {F!r})")


def max_deflection(F: float) -> tuple[float, float]:
    """(theta_max, beta_*) [rad]: the largest wedge angle with an attached jump at the Froude
    number F > 1, and the jump angle there (the root of d theta / d beta = 0 between the Mach
    angle and pi/2, where the weak and strong branches meet)."""
    _check_froude(F)
    lo, hi = math.asin(1.0 / F), 0.5 * math.pi
    # d theta / d beta > 0 just above the Mach angle and -> -infinity at pi/2
    b = brentq(lambda v: _dtheta_dbeta(F, v), lo + 1e-15 * hi, hi * (1 - 1e-15), xtol=1e-15,
               rtol=_EPS)  # fmt: skip
    return deflection_angle(F, b), b


def shock_angle(F: float, theta: float, branch: str = "weak") -> float:
    """beta [rad] of the attached jump at a wedge of deflection theta [rad] (0 <= theta <=
    theta_max) in a stream of Froude number F > 1, on the 'weak' or 'strong' branch.
    theta = 0 gives the Mach angle (weak) or pi/2 (strong, the normal jump).

    Raises ValueError for F <= 1 or theta > theta_max(F): no attached jump exists there, it
    detaches from the tip (see `detachment_froude`)."""
    if branch not in ("weak", "strong"):
        raise ValueError(f"branch must be 'weak' or 'strong', got {branch!r}")
    if theta < 0:
        raise ValueError(f"the wedge must turn the flow into itself, theta >= 0 (got {theta!r})")
    tmax, bstar = max_deflection(F)
    if theta > tmax:
        if theta - tmax > 1e-13:
            raise ValueError(
                f"theta = {math.degrees(theta):.6g} deg exceeds the detachment angle "
                f"theta_max = {math.degrees(tmax):.6g} deg at F = {F:.6g}: the jump detaches"
            )
        return bstar
    if theta == 0:
        return math.asin(1.0 / F) if branch == "weak" else 0.5 * math.pi
    f = lambda b: deflection_angle(F, b) - theta
    if branch == "weak":
        return brentq(f, math.asin(1.0 / F), bstar, xtol=1e-15, rtol=_EPS)
    return brentq(f, bstar, 0.5 * math.pi, xtol=1e-15, rtol=_EPS)


def detachment_froude(theta: float) -> float:
    """F_d [-]: the Froude number at which a wedge of deflection theta [rad], 0 < theta <
    pi/2, has theta_max(F_d) = theta; jumps stay attached for F > F_d and detach below."""
    if not 0 < theta < 0.5 * math.pi:
        raise ValueError(f"need 0 < theta < pi/2, got theta = {theta!r}")
    hi = 2.0
    while max_deflection(hi)[0] < theta:
        hi *= 2.0
        if hi > 1e12:
            raise ValueError(f"theta = {theta!r} is too close to pi/2 to resolve F_d")
    lo = 1.0 + 1e-12
    return brentq(lambda F: max_deflection(F)[0] - theta, lo, hi, xtol=1e-14, rtol=_EPS)


@dataclass(frozen=True)
class ObliqueJump:
    """The attached jump at a wedge: beta [rad], depth ratio h_2/h_1, speed ratio V_2/V_1,
    normal Froude number F sin(beta) and downstream Froude number F_2 (all dimensionless)."""

    beta: float
    depth_ratio: float
    speed_ratio: float
    normal_froude: float
    downstream_froude: float


def oblique_jump(F: float, theta: float, branch: str = "weak") -> ObliqueJump:
    """The jump (`ObliqueJump`) at a wedge of deflection theta [rad] in a stream of Froude
    number F; ValueError where it detaches (as `shock_angle`)."""
    beta = shock_angle(F, theta, branch)
    fn = F * math.sin(beta)
    r = jump_depth_ratio(fn)
    speed = math.cos(beta) / math.cos(beta - theta) if beta < 0.5 * math.pi else 1.0 / r
    return ObliqueJump(beta, r, speed, fn, F * speed / math.sqrt(r))


def downstream_state(h1: float, u1: float, theta: float, branch="weak", g=G, zeta=0.0):
    """(h_2 [m], u_2 [m/s], v_2 [m/s], beta [rad]) behind the jump at a wedge wall turned by
    theta [rad] towards +y from a stream (h_1 [m], u_1 > 0 [m/s], v = 0) along +x, with
    g' = g cos(zeta). The jump line leaves the wedge tip at the angle beta to +x."""
    F = u1 / math.sqrt(g * math.cos(zeta) * h1)
    j = oblique_jump(F, theta, branch)
    v2 = j.speed_ratio * u1
    return j.depth_ratio * h1, v2 * math.cos(theta), v2 * math.sin(theta), j.beta
