"""Second-order damped Runge-Kutta-Chebyshev (Sommeijer, Shampine & Verwer 1997).

The paper integrates with a Chebyshev-type method (Medovikov 1998); RKC is the better documented
member of the family. s stages stretch the real stability interval to
beta(s) ~ 0.653 s^2, so the viscous stiffness costs O(sqrt(rho dt)) evaluations instead of a
step ~ 1/rho. The step itself is set by the convective CFL; the stage count by
s = 1 + floor(sqrt(1 + 1.54 dt rho)), which keeps dt rho <= beta(s) with a ~2 % margin.

Only two previous stages are kept (Y_{j-1}, Y_{j-2}) besides Y0 and F0: 4 slots (F(Y_{j-1})
is used by one stage only and never stored: op.stage).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ...errors import InputError
from .base import RATE, Stepper, register

DAMPING = 2.0 / 13.0


@lru_cache(maxsize=512)
def rkc_coefficients(s: int, eps: float = DAMPING):
    """(mu_t1, [(mu_j, nu_j, mu_t_j, gamma_t_j) for j = 2..s], c) with stage times c[0..s]."""
    if s < 2:
        raise ValueError("RKC needs at least 2 stages")
    w0 = 1.0 + eps / (s * s)
    # Chebyshev T_j(w0) and its first two derivatives by the three-term recurrences
    T, dT, ddT = [1.0, w0], [0.0, 1.0], [0.0, 0.0]
    for j in range(2, s + 1):
        T.append(2 * w0 * T[j - 1] - T[j - 2])
        dT.append(2 * w0 * dT[j - 1] - dT[j - 2] + 2 * T[j - 1])
        ddT.append(2 * w0 * ddT[j - 1] - ddT[j - 2] + 4 * dT[j - 1])
    w1 = dT[s] / ddT[s]
    b = [0.0] * (s + 1)
    for j in range(2, s + 1):
        b[j] = ddT[j] / (dT[j] ** 2)
    b[0] = b[1] = b[2]
    a = [1.0 - b[j] * T[j] for j in range(s + 1)]
    mu_t1 = b[1] * w1
    c = [0.0] * (s + 1)
    c[1] = mu_t1
    coeffs = []
    for j in range(2, s + 1):
        mu = 2 * b[j] * w0 / b[j - 1]
        nu = -b[j] / b[j - 2]
        mu_t = 2 * b[j] * w1 / b[j - 1]
        gamma_t = -a[j - 1] * mu_t
        c[j] = mu * c[j - 1] + nu * c[j - 2] + mu_t * (1.0 - a[j - 1])
        coeffs.append((mu, nu, mu_t, gamma_t))
    return mu_t1, tuple(coeffs), tuple(c)


def stages_for(dt_rho: float) -> int:
    """Smallest safe stage count for dt * rho (at least 2)."""
    return max(2, 1 + int(math.floor(math.sqrt(1.0 + 1.54 * max(dt_rho, 0.0)))))


@register
class RKC(Stepper):
    name = "rkc"
    slots = 4
    order = 2
    stage_cap = True

    def __init__(self, max_stages: int = 200):
        self.max_stages = max(2, int(max_stages))

    def plan(self, dt_cfl, rho, dt_max, stages=None):
        dt = min(dt_cfl, dt_max)
        if stages is not None:
            if not (isinstance(stages, int) and stages >= 2):
                raise InputError(f"stages={stages!r}: RKC needs an integer of at least 2")
            return dt, stages
        s = stages_for(dt * rho)
        if s > self.max_stages:
            # the stage cap binds: shorten the step so that dt rho fits beta(max_stages)
            s = self.max_stages
            dt = min(dt, ((s - 1) ** 2 - 1) / (1.54 * rho))
        return dt, s

    def step(self, op, t, dt, stages):
        s = stages
        mu_t1, coeffs, c = rkc_coefficients(s)
        Y0, F0, A, B = 0, 1, 2, 3
        op.rhs(Y0, F0, t)
        # Y1; tau: the stage's own time advance, over which the friction is projected (a
        # projected friction scheme), c_j - (mu c_{j-1} + nu c_{j-2}) = (mu_t + gamma_t) dt
        op.combine(A, [(1.0, Y0), (mu_t1 * dt, F0)], limit=True, tau=mu_t1 * dt, rates=(F0,))
        prev2, prev1 = Y0, A
        for j in range(2, s + 1):
            mu, nu, mu_t, gamma_t = coeffs[j - 2]
            # Y_j overwrites Y_{j-2} (element-wise update), except that Y0 must survive until
            # the last stage, which writes the new solution into slot 0 itself. F(Y_{j-1}) is
            # needed by this stage alone: fused into it, never stored.
            dst = Y0 if j == s else (B if prev2 == Y0 else prev2)
            op.stage(
                dst,
                [
                    (1.0 - mu - nu, Y0),
                    (mu, prev1),
                    (nu, prev2),
                    (mu_t * dt, RATE),
                    (gamma_t * dt, F0),
                ],
                prev1,
                t + c[j - 1] * dt,
                tau=(mu_t + gamma_t) * dt,
                rates=(F0,),
            )
            prev2, prev1 = prev1, dst

    def step_members(self, op, t, dt, stages):
        """RKC.step of each member of a batch with its own stage count: stage j is taken by
        the members with at least j stages, with each member's own coefficients; a member's
        last stage writes its slot 0, the later ones leave it out."""
        s, mu_t1, stage_numbers = member_tables(stages)
        Y0, F0, A, B = 0, 1, 2, 3
        op.rhs(Y0, F0, t)
        op.combine(A, [(1.0, Y0), (mu_t1 * dt, F0)], limit=True, tau=mu_t1 * dt, rates=(F0,))
        prev2, prev1 = Y0, A
        for j in range(2, int(s.max()) + 1):
            mu, nu, mu_t, gamma_t, c_prev = stage_numbers(j)
            common = B if prev2 == Y0 else prev2  # (the slot of a member not yet at its last)
            op.stage(
                np.where(s == j, Y0, common),
                [
                    (1.0 - mu - nu, Y0),
                    (mu, prev1),
                    (nu, prev2),
                    (mu_t * dt, RATE),
                    (gamma_t * dt, F0),
                ],
                prev1,
                t + c_prev * dt,
                tau=(mu_t + gamma_t) * dt,
                rates=(F0,),
                live=s >= j,
            )
            prev2, prev1 = prev1, common


def member_tables(stages):
    """Each member's RKC numbers for stage counts ``stages`` (one per member): (s as an
    array, mu~_1 per member, a function of the stage j giving arrays of (mu_j, nu_j, mu~_j,
    gamma~_j, c_{j-1}) with zeros for the members of fewer stages)."""
    s = np.asarray([int(k) for k in stages])
    tables = [rkc_coefficients(int(k)) for k in s]
    mu_t1 = np.array([tb[0] for tb in tables])

    def stage_numbers(j: int):
        rows = np.zeros((5, len(s)))
        for e, (_, coeffs, c) in enumerate(tables):
            if j <= s[e]:
                rows[:4, e] = coeffs[j - 2]
                rows[4, e] = c[j - 1]
        return tuple(rows)

    return s, mu_t1, stage_numbers
