"""Steady one-dimensional shallow-water flow over a bump b(x): the three classical cases of
Goutal & Maurel (1997) collected in SWASHES (Delestre et al. 2013, Int. J. Numer. Meth.
Fluids 72, 269; the report arXiv:1110.0288, section 3.1.1).

A steady flow keeps its discharge q = h u and, where it is smooth and frictionless, its
Bernoulli head

    u^2 / 2 + g (h + b) = g H,    so    q^2 / (2 g h^2) + h + b(x) = H,        (1)

a cubic h^3 + (b - H) h^2 + q^2 / (2 g) = 0 for h at each x. Its two positive roots lie on
either side of the critical depth h_c = (q^2 / g)^(1/3) (Froude number u / sqrt(g h) = 1):
the subcritical branch (h > h_c, Fr < 1) and the supercritical one (h < h_c, Fr > 1). Both
exist where H >= H_min(x) = (3/2) h_c + b(x); where H < H_min the flow is choked and no smooth
steady flow with that head passes. A stationary jump keeps q and the momentum flux

    M(h) = q^2 / h + g h^2 / 2                                                 (2)

(Rankine-Hugoniot for a shock at rest), joining a supercritical h_1 to its conjugate
subcritical h_2 = (h_1 / 2) (sqrt(1 + 8 Fr_1^2) - 1).

On a plane inclined at zeta, with b measured normal to it, the same holds with
g -> g cos(zeta) where the along-slope gravity g sin(zeta) is balanced: by a Coulomb friction
tan(delta) = tan(zeta) while u > 0, or trivially on a level bed (zeta = 0, the classical case).
Every function here takes g and zeta and uses g cos(zeta).

Three flows on [x_0, x_1] with the crest of b (its maximum) inside:

* `subcritical_flow`: q and the outflow depth h_out fix H = h_out + q^2 / (2 g h_out^2);
  subcritical everywhere, valid if H >= H_min at the crest (Goutal & Maurel: q = 4.42 m^2/s,
  h_out = 2 m, b = 0.2 - 0.05 (x - 10)^2 on 8 < x < 12);
* `transcritical_flow`: critical at the crest, H = (3/2) h_c + b_max; subcritical upstream,
  supercritical downstream of the crest (q = 1.53 m^2/s);
* `transcritical_shock_flow`: as the last, until a stationary jump at x_s to the subcritical
  branch of the outflow head (q = 0.18 m^2/s, h_out = 0.33 m); x_s solves
  M(h_super(x_s)) = M(h_sub(x_s)) (`bump_shock_position`).

Houghton & Kasahara (1968), Comm. Pure Appl. Math. 21, 1 give the theory; Goutal & Maurel
(1997), Proc. 2nd Workshop on Dam-Break Wave Simulation, EDF-DER HE-43/97/016/B, the cases.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq, minimize_scalar

G = 9.81


def critical_depth(q: float, g: float = G, zeta: float = 0.0) -> float:
    """h_c = (q^2 / g')^(1/3) [m], g' = g cos(zeta); q in m^2/s."""
    return (q * q / (g * math.cos(zeta))) ** (1.0 / 3.0)


def momentum_flux(h, q: float, g: float = G, zeta: float = 0.0):
    """M(h) = q^2 / h + g' h^2 / 2 [m^3/s^2], kept across a stationary jump (2)."""
    h = np.asarray(h, dtype=float)
    return q * q / h + 0.5 * g * math.cos(zeta) * h * h


def bernoulli_depth(b: float, q: float, head: float, branch: str, g=G, zeta=0.0) -> float:
    """The root h [m] of (1) at a bed height b [m] for the head H [m] on the branch
    'sub' (h >= h_c) or 'super' (h <= h_c). Raises ValueError where H < H_min (choked);
    returns h_c where H = H_min to round-off."""
    if branch not in ("sub", "super"):
        raise ValueError(f"branch must be 'sub' or 'super', got {branch!r}")
    gc = g * math.cos(zeta)
    hc = critical_depth(q, g, zeta)
    a = q * q / (2 * gc)
    f = lambda h: a / (h * h) + h + b - head
    fmin = f(hc)
    if fmin >= 0:
        if fmin > 1e-12 * max(abs(head), hc):
            raise ValueError(
                f"the head H = {head:.6g} m is below the minimum {head - fmin:.6g} m at a "
                f"bed height {b:.6g} m: the flow is choked there (no smooth steady flow)"
            )
        return hc
    if branch == "sub":  # f(H - b) = a / (H - b)^2 > 0
        lo, hi = hc, head - b
    else:  # f(sqrt(a / (H - b))) = sqrt(a / (H - b)) > 0
        lo, hi = math.sqrt(a / (head - b)), hc
    return brentq(f, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps)


def _depths(x, bump, q, head, branch, g, zeta):
    x = np.asarray(x, dtype=float)
    h = np.array([bernoulli_depth(float(bump(xi)), q, head, branch, g, zeta) for xi in x.flat])
    return h.reshape(x.shape)


def bump_crest(bump, x0: float, x1: float) -> tuple[float, float]:
    """(x_crest, b_max): the maximum of the callable bump(x) on [x0, x1], sampled on 4001 points
    and refined with a bounded Brent search between the neighbours of the best sample."""
    xs = np.linspace(x0, x1, 4001)
    bs = np.array([float(bump(v)) for v in xs])
    i = int(np.argmax(bs))
    lo, hi = xs[max(i - 1, 0)], xs[min(i + 1, xs.size - 1)]
    r = minimize_scalar(lambda v: -float(bump(v)), bounds=(lo, hi), method="bounded",
                        options={"xatol": 1e-12})  # fmt: skip
    xc = float(r.x) if -r.fun >= bs[i] else float(xs[i])
    return xc, float(bump(xc))


def outflow_head(q: float, h_out: float, b_out: float = 0.0, g=G, zeta=0.0) -> float:
    """H = h_out + b_out + q^2 / (2 g' h_out^2) [m]: the head a subcritical outflow fixes
    (ValueError if h_out is below the critical depth: a supercritical outflow fixes nothing)."""
    if not h_out > critical_depth(q, g, zeta):
        raise ValueError(
            f"the outflow depth {h_out!r} m is not subcritical (h_c = "
            f"{critical_depth(q, g, zeta):.6g} m): it cannot control the flow"
        )
    return h_out + b_out + q * q / (2 * g * math.cos(zeta) * h_out * h_out)


def subcritical_flow(x, bump, q: float, h_out: float, g=G, zeta=0.0):
    """(h, u) [m, m/s] at the points x [m] of the subcritical flow with discharge q [m^2/s]
    and depth h_out [m] at the outflow x[-1] (the largest x). ValueError if the head is
    too small to pass the crest subcritically (the flow would be transcritical)."""
    x = np.asarray(x, dtype=float)
    head = outflow_head(q, h_out, float(bump(x.max())), g, zeta)
    h = _depths(x, bump, q, head, "sub", g, zeta)
    return h, q / h


def transcritical_flow(x, bump, q: float, g=G, zeta=0.0):
    """(h, u) at the points x of the smooth transcritical flow: critical depth at the crest
    of the bump on [min x, max x], subcritical upstream of it and supercritical downstream
    (H = (3/2) h_c + b_max). The outflow depth plays no part (the outflow is supercritical)."""
    x = np.asarray(x, dtype=float)
    xc, bmax = bump_crest(bump, x.min(), x.max())
    head = 1.5 * critical_depth(q, g, zeta) + bmax
    h = np.empty(x.shape)
    up = x <= xc
    h[up] = _depths(x[up], bump, q, head, "sub", g, zeta)
    h[~up] = _depths(x[~up], bump, q, head, "super", g, zeta)
    return h, q / h


def bump_shock_position(bump, q: float, h_out: float, x0: float, x1: float, g=G, zeta=0.0):
    """x_s [m]: where the supercritical branch of the critical head (1.5 h_c + b_max) and
    the subcritical branch of the outflow head (h_out at x1) have equal momentum flux (2),
    between the crest and x1 (b is taken to fall monotonically from the crest to x1).
    ValueError where no such point exists: the jump would be swept out of [x0, x1] (outflow
    too shallow) or the outflow head is too large for the flow to become critical at the
    crest (then the flow is subcritical)."""
    xc, bmax = bump_crest(bump, x0, x1)
    hc = critical_depth(q, g, zeta)
    h_crit = 1.5 * hc + bmax
    h_down = outflow_head(q, h_out, float(bump(x1)), g, zeta)
    if h_down >= h_crit:
        raise ValueError(
            f"the outflow head {h_down:.6g} m reaches the crest's critical head {h_crit:.6g} m:"
            " the flow stays subcritical (use subcritical_flow)"
        )

    def jump(v):
        b = float(bump(v))
        h1 = bernoulli_depth(b, q, h_crit, "super", g, zeta)
        h2 = bernoulli_depth(b, q, h_down, "sub", g, zeta)
        return float(momentum_flux(h1, q, g, zeta) - momentum_flux(h2, q, g, zeta))

    # the subcritical branch of the outflow head exists only where H_min(x) <= h_down: from
    # x_a, where it is critical (M(h_c) is the least momentum flux, so jump(x_a) >= 0)
    xa = brentq(lambda v: float(bump(v)) + 1.5 * hc - h_down, xc, x1, xtol=1e-14)
    if jump(x1) > 0:
        raise ValueError("the momentum fluxes never balance before x1: the outflow depth is"
                         " too small to hold a stationary jump in the domain")  # fmt: skip
    return brentq(jump, xa, x1, xtol=1e-13, rtol=4 * np.finfo(float).eps)


def transcritical_shock_flow(x, bump, q: float, h_out: float, g=G, zeta=0.0):
    """(h, u, x_s) at the points x: transcritical over the crest, supercritical down to the
    stationary jump at x_s (`bump_shock_position` on [min x, max x]), subcritical with the
    outflow head beyond. At x == x_s the downstream (subcritical) state is returned."""
    x = np.asarray(x, dtype=float)
    x0, x1 = x.min(), x.max()
    xc, bmax = bump_crest(bump, x0, x1)
    xs = bump_shock_position(bump, q, h_out, x0, x1, g, zeta)
    h_crit = 1.5 * critical_depth(q, g, zeta) + bmax
    h_down = outflow_head(q, h_out, float(bump(x1)), g, zeta)
    h = np.empty(x.shape)
    up, mid = x <= xc, (x > xc) & (x < xs)
    down = ~(up | mid)
    h[up] = _depths(x[up], bump, q, h_crit, "sub", g, zeta)
    h[mid] = _depths(x[mid], bump, q, h_crit, "super", g, zeta)
    h[down] = _depths(x[down], bump, q, h_down, "sub", g, zeta)
    return h, q / h, xs


def goutal_maurel_bump(x):
    """b(x) = 0.2 - 0.05 (x - 10)^2 for 8 < x < 12, 0 elsewhere [m] (Goutal & Maurel 1997),
    on the channel [0, 25] m."""
    x = np.asarray(x, dtype=float)
    return np.where((x > 8) & (x < 12), 0.2 - 0.05 * (x - 10) ** 2, 0.0)
