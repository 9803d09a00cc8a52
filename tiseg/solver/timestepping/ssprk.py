"""Strong-stability-preserving Runge-Kutta steppers (Shu & Osher 1988) and forward Euler.

They are convex combinations of Euler steps, so they keep the positivity of the KT scheme
(Kurganov & Petrova 2007) for steps up to ``ssp`` times the forward-Euler limit ``dt_cfl``
(their SSP coefficient C). Per evaluation they advance C / stages of it: 1/2 for SSPRK2, 1/3 for
SSPRK3, 3/4 for SSPRK(4,2), 9/10 for SSPRK(10,2), 3/5 for SSPRK(10,4), 2/3 for SSPRK(9,3) and
3/4 for SSPRK(16,3) (Ketcheson 2008, SIAM J. Sci. Comput. 30, 2113). Their real stability
interval [-beta, 0] must also contain the operator's spectrum: dt <= safety * beta / rho.
"""

from __future__ import annotations

from ...errors import InputError
from .base import RATE, Stepper, register


class _ExplicitRK(Stepper):
    beta = 2.0  # real stability interval
    safety = 0.9
    ssp = 1.0  # SSP coefficient: positive for dt <= ssp * dt_cfl

    def plan(self, dt_cfl, rho, dt_max, stages=None):
        if stages is not None and stages != self.stages:
            raise InputError(f"stages={stages!r}: {self.name} always takes {self.stages} stage(s)")
        dt = self.ssp * dt_cfl
        if rho > 0:
            dt = min(dt, self.safety * self.beta / rho)
        return min(dt, dt_max), self.stages


@register
class Euler(_ExplicitRK):
    name = "euler"
    slots = 1
    order = 1
    stages = 1

    def step(self, op, t, dt, stages):
        op.stage(0, [(1.0, 0), (dt, RATE)], 0, t)


@register
class SSPRK2(_ExplicitRK):
    name = "ssprk2"
    slots = 3
    order = 2
    stages = 2

    def step(self, op, t, dt, stages):
        op.stage(2, [(1.0, 0), (dt, RATE)], 0, t)
        op.stage(0, [(0.5, 0), (0.5, 2), (0.5 * dt, RATE)], 2, t + dt)


@register
class SSPRK3(_ExplicitRK):
    name = "ssprk3"
    slots = 3
    order = 3
    stages = 3
    beta = 2.51

    def step(self, op, t, dt, stages):
        op.stage(2, [(1.0, 0), (dt, RATE)], 0, t)
        op.stage(2, [(0.75, 0), (0.25, 2), (0.25 * dt, RATE)], 2, t + dt)
        op.stage(0, [(1.0 / 3.0, 0), (2.0 / 3.0, 2), (2.0 / 3.0 * dt, RATE)], 2, t + 0.5 * dt)


class _SSPRKs2(_ExplicitRK):
    """Ketcheson's (2008) SSPRK(s,2): s - 1 Euler steps of dt/(s - 1), then the average of the
    start with one more Euler step, u := u/s + (s - 1)/s (Y + dt/(s - 1) F(Y)). C = s - 1 at s
    evaluations; R(z) = (s - 1)/s (1 + z/(s - 1))^s + 1/s stays within the unit disc on
    [-2 (s - 1), 0] for even s. Three state slots whatever s."""

    slots = 3
    order = 2

    def step(self, op, t, dt, stages):
        m = self.stages - 1
        h = dt / m
        op.stage(2, [(1.0, 0), (h, RATE)], 0, t)
        for k in range(1, m):
            op.stage(2, [(1.0, 2), (h, RATE)], 2, t + k * h)
        s = self.stages
        op.stage(0, [(1.0 / s, 0), (m / s, 2), (dt / s, RATE)], 2, t + dt)


@register
class SSPRK42(_SSPRKs2):
    name = "ssprk4_2"
    stages = 4
    beta = 6.0
    ssp = 3.0


@register
class SSPRK102(_SSPRKs2):
    """C = 9 at 10 evaluations: 0.9 Euler steps per evaluation, the most of these steppers."""

    name = "ssprk10_2"
    stages = 10
    beta = 18.0
    ssp = 9.0


@register
class SSPRK104(_ExplicitRK):
    """Ketcheson's (2008) low-storage SSPRK(10,4): fourth order, C = 6 at 10 evaluations, two
    registers. Five Euler steps of dt/6; the convex mix q1 := 3/5 u + 2/5 q1 (written, as in
    the paper, through q2 = u/25 + 9 q1/25 and q1 = 15 q2 - 5 q1); four more Euler steps; and
    u := q2 + 3/5 q1 + dt/10 F(q1). The real stability interval is [-13.9, 0]."""

    name = "ssprk10_4"
    slots = 4
    order = 4
    keeps_rest = False  # its mixing stage combines a partial sum, unlimited: rest to round-off
    stages = 10
    beta = 13.9
    ssp = 6.0

    def step(self, op, t, dt, stages):
        h = dt / 6.0
        Q1, Q2 = 2, 3
        op.stage(Q1, [(1.0, 0), (h, RATE)], 0, t)
        for k in range(1, 5):
            op.stage(Q1, [(1.0, Q1), (h, RATE)], Q1, t + k * h)
        # q2 is a scaled partial sum, not a state: no limiter on it
        op.combine(Q2, [(1.0 / 25.0, 0), (9.0 / 25.0, Q1)], limit=False)
        op.combine(Q1, [(15.0, Q2), (-5.0, Q1)], limit=True)  # = 3/5 u + 2/5 q1, at t + dt/3
        for k in range(4):
            op.stage(Q1, [(1.0, Q1), (h, RATE)], Q1, t + dt / 3.0 + k * h)
        op.stage(0, [(1.0, Q2), (0.6, Q1), (0.1 * dt, RATE)], Q1, t + dt)


class _SSPRKn2_3(_ExplicitRK):
    """Ketcheson's (2008) third-order SSPRK(n^2, 3): n^2 Euler steps of dt/r, r = n^2 - n,
    one of them replaced by a convex mix with the state saved after (n - 1)(n - 2)/2 steps:

        q1 := u; (n-1)(n-2)/2 Euler steps; q2 := q1;
        Euler steps up to step n(n+1)/2 - 1; q1 := (n q2 + (n-1) (q1 + dt/r F(q1))) / (2n - 1);
        n(n-1)/2 more Euler steps; u := q1.

    C = r at n^2 evaluations: third order at SSPRK(4,2)'s 3/4 Euler steps per evaluation for
    n = 4, so its time error is that of a third-order method at a second-order method's price.
    n = 2 is the classical SSPRK(4,3). The mixed state lies at t + dt/2."""

    slots = 4
    order = 3
    n = 3

    def step(self, op, t, dt, stages):
        n = self.n
        h = dt / (n * n - n)
        Q1, Q2 = 2, 3
        k_save = (n - 1) * (n - 2) // 2
        k_mix = n * (n + 1) // 2 - 1  # Euler steps before the mixing stage
        cur, k = 0, 0  # the slot holding the latest stage, and its time in units of h

        def euler(dst):
            nonlocal cur, k
            op.stage(dst, [(1.0, cur), (h, RATE)], cur, t + k * h)
            cur, k = dst, k + 1

        for _ in range(k_save):
            euler(Q1)
        op.combine(Q2, [(1.0, cur)])  # a copy of a limited state: no limiter needed
        while k < k_mix:
            euler(Q1)
        a, b = n / (2 * n - 1), (n - 1) / (2 * n - 1)
        op.stage(Q1, [(a, Q2), (b, cur), (b * h, RATE)], cur, t + k * h)
        cur, k = Q1, (n * k_save + (n - 1) * (k_mix + 1)) / (2 * n - 1)
        for m in range(n * (n - 1) // 2):
            euler(0 if m == n * (n - 1) // 2 - 1 else Q1)


@register
class SSPRK93(_SSPRKn2_3):
    name = "ssprk9_3"
    stages = 9
    n = 3
    ssp = 6.0
    beta = 13.2  # |R(-13.28)| = 1


@register
class SSPRK163(_SSPRKn2_3):
    name = "ssprk16_3"
    stages = 16
    n = 4
    ssp = 12.0
    beta = 25.4  # |R(-25.42)| = 1
