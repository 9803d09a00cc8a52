"""Strong-stability-preserving Runge-Kutta steppers (Shu & Osher 1988) and forward Euler.

They are convex combinations of Euler steps, so they keep the positivity of the KT scheme
(Kurganov & Petrova 2007) under the CFL limit. Their real stability interval [-beta, 0] must also
contain the operator's spectrum: dt <= safety * beta / rho.
"""

from __future__ import annotations

from ..errors import InputError
from .base import Stepper, register


class _ExplicitRK(Stepper):
    beta = 2.0  # real stability interval
    safety = 0.9

    def plan(self, dt_cfl, rho, dt_max, stages=None):
        if stages is not None and stages != self.stages:
            raise InputError(f"stages={stages!r}: {self.name} always takes {self.stages} stage(s)")
        dt = dt_cfl
        if rho > 0:
            dt = min(dt, self.safety * self.beta / rho)
        return min(dt, dt_max), self.stages


@register
class Euler(_ExplicitRK):
    name = "euler"
    slots = 2
    order = 1
    stages = 1

    def step(self, op, t, dt, stages):
        op.rhs(0, 1, t)
        op.combine(0, [(1.0, 0), (dt, 1)], limit=True)


@register
class SSPRK2(_ExplicitRK):
    name = "ssprk2"
    slots = 3
    order = 2
    stages = 2

    def step(self, op, t, dt, stages):
        op.rhs(0, 1, t)
        op.combine(2, [(1.0, 0), (dt, 1)], limit=True)
        op.rhs(2, 1, t + dt)
        op.combine(0, [(0.5, 0), (0.5, 2), (0.5 * dt, 1)], limit=True)


@register
class SSPRK3(_ExplicitRK):
    name = "ssprk3"
    slots = 3
    order = 3
    stages = 3
    beta = 2.51

    def step(self, op, t, dt, stages):
        op.rhs(0, 1, t)
        op.combine(2, [(1.0, 0), (dt, 1)], limit=True)
        op.rhs(2, 1, t + dt)
        op.combine(2, [(0.75, 0), (0.25, 2), (0.25 * dt, 1)], limit=True)
        op.rhs(2, 1, t + 0.5 * dt)
        op.combine(0, [(1.0 / 3.0, 0), (2.0 / 3.0, 2), (2.0 / 3.0 * dt, 1)], limit=True)
