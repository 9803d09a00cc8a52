"""Exact and reference solutions of the verification problems, found by the name a problem file
gives in its ``[exact]`` table.

Each entry computes, from the problem's scene (and the table's parameters), what a run is
scored against: exact cell averages of a field along the grid, or a number (a growth rate).
``finest-run`` is the one entry without a formula: the error is measured against the same
problem run at a finer resolution (``resolution = {full = .., quick = ..}``), which the study
runs as its reference point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ...model.exact_dambreak import cell_averages, ritter, stoker
from ...model.exact_friction import ParabolicCap, coulomb_dam_break, sliding_layer
from ...setup.initial import channel_fraction, eigenmode
from .steady_channel import channel_profile

FIELD, RATE, FINER_RUN = "field", "rate", "finer run"  # what a solution gives (a score takes)


@dataclass(frozen=True)
class Solution:
    """A registered exact or reference solution.

    ``gives``: FIELD (cell values along the scored cut), RATE (one number) or FINER_RUN.
    ``params``: the parameters the ``[exact]`` table must give (name -> meaning).
    ``compute(scene, **params)``: the solution (None for FINER_RUN)."""

    name: str
    doc: str
    gives: str
    params: dict
    compute: Callable | None


def transport_exact(x, t, L=0.1, u0=0.2, mean=0.5, amp=0.25):
    """phi of phi_t + (u0 (phi - G(phi)))_x = 0, phi(x, 0) = mean + amp cos(2 pi x / L), by
    characteristics phi = phi(x - u0 (1 - G'(phi)) t, 0); vectorised bisection (the root is
    unique before the breaking time). G(phi) = alpha phi (1 - phi) with alpha = 1/7 (2.17)."""
    x = np.asarray(x, dtype=float)
    lo = np.full_like(x, mean - amp - 1e-12)
    hi = np.full_like(x, mean + amp + 1e-12)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        speed = u0 * (1.0 / 7.0 + 12.0 * mid / 7.0)  # u0 (1 - G'(phi)), alpha = 1/7
        f = mid - (mean + amp * np.cos(2 * np.pi * (x - speed * t) / L))
        lo = np.where(f < 0, mid, lo)
        hi = np.where(f < 0, hi, mid)
    return 0.5 * (lo + hi)


def _transport(scene, L, u0, mean, amp):
    x, _ = scene.domain.cell_centres()
    # exact cell averages by 3-point Gauss quadrature (error << the scheme's)
    g = np.array([-math.sqrt(0.6), 0.0, math.sqrt(0.6)]) * 0.5 * scene.dx
    w = np.array([5.0, 8.0, 5.0]) / 18.0
    return sum(wk * transport_exact(x + gk, scene.t_end, L, u0, mean, amp) for gk, wk in zip(g, w))


def _dam_break(scene):
    """Cell averages of h at t_end: Ritter's solution onto a dry bed, Stoker's onto a wet one
    (the scene's initial.x0, h_left, h_right; flat frictionless bed)."""
    ini = scene.initial
    x, _ = scene.domain.cell_centres()
    t = scene.t_end
    if ini.h_right == 0.0:
        return cell_averages(lambda p: ritter(p, t, ini.h_left, ini.x0)[0], x, scene.dx)
    return cell_averages(lambda p: stoker(p, t, ini.h_left, ini.h_right, ini.x0)[0], x, scene.dx)


def _friction_angles(scene):
    """(zeta, delta) [rad] of a scene with Coulomb friction (effects.coulomb_mu = tan delta)."""
    if scene.effects.friction != "coulomb":
        raise ValueError("the exact solutions with friction need effects.friction = 'coulomb'")
    return math.radians(scene.material.zeta_deg), math.atan(scene.effects.coulomb_mu)


def _coulomb_dam_break(scene):
    """Cell averages of h at t_end of the dam break with Coulomb friction (Mangeney et al.
    2000): the scene's initial.x0 and h_left onto a dry bed, its slope and coulomb_mu."""
    ini = scene.initial
    zeta, delta = _friction_angles(scene)
    x, _ = scene.domain.cell_centres()
    g = scene.material.g
    return cell_averages(
        lambda p: coulomb_dam_break(p, scene.t_end, ini.h_left, zeta, delta, ini.x0, g)[0],
        x,
        scene.dx,
    )


def _sliding_layer(scene):
    """u at t_end of the scene's uniform layer (flow.h0, flow.u0) sliding under Coulomb
    friction, in every cell: u0 + m t until it stops, then 0."""
    zeta, delta = _friction_angles(scene)
    u, _ = sliding_layer(scene.t_end, scene.flow.u0, zeta, delta, scene.material.g)
    x, _ = scene.domain.cell_centres()
    return np.full(len(x), float(u))


def _parabolic_cap(scene):
    """Cell averages of h at t_end of the parabolic cap (initial.kind = "cap") sliding under
    Coulomb friction (Savage & Hutter 1991's similarity solution)."""
    ini = scene.initial
    zeta, delta = _friction_angles(scene)
    cap = ParabolicCap(ini.x0, ini.half_width, ini.h, ini.u, zeta, delta, scene.material.g)
    if not cap.valid_until(scene.t_end):
        raise ValueError("the cap's rear margin turns back before t_end: no closed form there")
    x, _ = scene.domain.cell_centres()
    return cell_averages(lambda p: cap(p, scene.t_end)[0], x, scene.dx, 32)


def _linear_growth_rate(scene):
    """sigma = Re(lambda) u0 / h0 [1/s] of the scene's most unstable mode, (5.19)-(5.21)."""
    lam, _ = eigenmode(scene)
    return lam.real * scene.flow.u0 / scene.flow.h0


def channel_cells(scene):
    """Cell centres across the slope and the fraction of each cell inside the channel."""
    y = (np.arange(scene.domain.ny) + 0.5) * scene.dy
    return y, channel_fraction(y, scene.dy, scene.domain.Ly, scene.initial.width)


def _channel_unchanged(scene):
    """phi's initial cell averages across the channel, which the exact solution keeps for ever
    (no mass crosses the contacts)."""
    ini = scene.initial
    _, frac = channel_cells(scene)
    return ini.phi_levee + (ini.phi_channel - ini.phi_levee) * frac


def _channel_speed(scene):
    """Cell averages of the steady cross-slope speed profile u(y) (tiseg.post.problems.steady_channel)."""
    y, _ = channel_cells(scene)
    return channel_profile(scene).cell_averages(y, scene.dy)


SOLUTIONS: dict[str, Solution] = {
    s.name: s
    for s in (
        Solution(
            "transport-characteristics",
            "phi of smooth large-particle transport at uniform h, u (T6b), by characteristics",
            FIELD,
            {
                "L": "period [m]",
                "u0": "speed [m/s]",
                "mean": "mean phi",
                "amp": "amplitude of the cosine in phi",
            },
            _transport,
        ),
        Solution(
            "dam-break",
            "h of the frictionless dam break: Ritter (dry bed) or Stoker (wet bed)",
            FIELD,
            {},
            _dam_break,
        ),
        Solution(
            "coulomb-dam-break",
            "h of the dam break onto a dry slope with Coulomb friction (Mangeney et al. 2000)",
            FIELD,
            {},
            _coulomb_dam_break,
        ),
        Solution(
            "sliding-layer",
            "u of a uniform layer sliding under Coulomb friction until it stops",
            FIELD,
            {},
            _sliding_layer,
        ),
        Solution(
            "parabolic-cap",
            "h of a parabolic cap sliding under Coulomb friction (Savage & Hutter 1991)",
            FIELD,
            {},
            _parabolic_cap,
        ),
        Solution(
            "linear-growth-rate",
            "growth rate of the scene's most unstable linear mode (5.19)-(5.21) [1/s]",
            RATE,
            {},
            _linear_growth_rate,
        ),
        Solution(
            "channel-unchanged",
            "phi across the channel: its initial cell averages, kept for ever",
            FIELD,
            {},
            _channel_unchanged,
        ),
        Solution(
            "channel-steady-speed",
            "u(y) of the steady cross-slope channel profile (tiseg.post.problems.steady_channel)",
            FIELD,
            {},
            _channel_speed,
        ),
        Solution(
            "finest-run",
            "the same problem at a finer resolution (weno + rkc + f64)",
            FINER_RUN,
            {"resolution": "{full = .., quick = ..}: the reference run's resolution"},
            None,
        ),
    )
}
