"""Exact solutions of the frictionless shallow-water dam break on a flat bed: Ritter (dry bed)
and Stoker (wet bed).

Both start from h = h_l for x < x0 and h = h_r beyond, at rest, with gravity g:

* `ritter` (h_r = 0): a rarefaction fan from x0 - c_l t to the dry front x0 + 2 c_l t,
  where c = (2 c_l - xi) / 3 and h = c^2 / g at xi = (x - x0) / t (Ritter 1892);
* `stoker` (h_r > 0): the fan, a constant star state (h*, u*) and a bore into the still
  right state (Stoker 1957). h* solves 2 (c_l - c*) = (h* - h_r) sqrt(g (h* + h_r) / (2 h* h_r)),
  the Riemann invariant of the fan equal to the bore's Rankine-Hugoniot velocity, and the bore
  runs at s = h* u* / (h* - h_r).

`cell_averages` turns a point solution into the cell averages a finite-volume scheme is
compared with.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

G = 9.81


def ritter(x, t: float, hl: float, x0: float = 0.0, g: float = G):
    """(h, u) of the Ritter solution at the points x and time t > 0."""
    cl = math.sqrt(g * hl)
    xi = (np.asarray(x, dtype=float) - x0) / t
    c = np.clip((2 * cl - xi) / 3, 0.0, cl)
    h = np.where(xi >= 2 * cl, 0.0, c * c / g)
    u = np.where((xi > -cl) & (xi < 2 * cl), 2 * (cl - c), 0.0)
    return h, u


def stoker_star(hl: float, hr: float, g: float = G) -> tuple[float, float, float]:
    """(h*, u*, bore speed) of the wet-bed dam break."""
    if not 0 < hr < hl:
        raise ValueError(f"need 0 < h_r < h_l, got h_l={hl!r}, h_r={hr!r}")
    cl = math.sqrt(g * hl)

    def mismatch(hs):
        return 2 * (cl - math.sqrt(g * hs)) - (hs - hr) * math.sqrt(g * (hs + hr) / (2 * hs * hr))

    hs = brentq(mismatch, hr, hl, xtol=1e-15, rtol=1e-15)
    us = 2 * (cl - math.sqrt(g * hs))
    return hs, us, hs * us / (hs - hr)


def stoker(x, t: float, hl: float, hr: float, x0: float = 0.0, g: float = G):
    """(h, u) of the Stoker solution at the points x and time t > 0."""
    hs, us, s = stoker_star(hl, hr, g)
    cl, cs = math.sqrt(g * hl), math.sqrt(g * hs)
    xi = (np.asarray(x, dtype=float) - x0) / t
    c = np.clip((2 * cl - xi) / 3, cs, cl)
    fan = (xi > -cl) & (xi < us - cs)
    h = np.where(xi <= -cl, hl, np.where(fan, c * c / g, np.where(xi < s, hs, hr)))
    u = np.where(fan, 2 * (cl - c), np.where((xi >= us - cs) & (xi < s), us, 0.0))
    return h, u


def cell_averages(f, x, dx: float, n: int = 16):
    """Mean of f over n sub-samples of each cell of width dx centred at x."""
    sub = ((np.arange(n) + 0.5) / n - 0.5) * dx
    return f(np.asarray(x, dtype=float)[..., None] + sub).mean(axis=-1)
