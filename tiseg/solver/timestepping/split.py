"""The dimensionally split MUSCL-Hancock step (tiseg.solver.numerics.split) as a stepper."""

from __future__ import annotations

import numpy as np

from ...errors import InputError
from .base import Stepper, register
from .rkc import member_tables, rkc_coefficients, stages_for


@register
class Hancock(Stepper):
    """One MUSCL-Hancock sweep per direction, in the order x, y on even steps and y, x on odd
    ones (the step's index comes from the simulation, ``index``, so a resumed run sweeps as
    the uninterrupted one did). The step is the convective limit itself: with step_rule
    "max" and numerics.cfl <= 1 (default 0.6) that is each sweep's Courant number. The
    friction is the projected one, after the step's last sub-step.

    With viscosity (``viscous``) a step is a symmetric pair of half steps of dt/2 each, with
    the viscous term of (6.2) as the sub-step V over the whole dt between them:

        x(dt/2) y(dt/2) | V(dt) | y(dt/2) x(dt/2)     (in 1D: x | V | x)

    Strang's splitting, second order. Each half projects the friction over its dt/2 at its
    end, as a step without viscosity does, and each sweep's Courant number is that of dt/2,
    so `plan` makes dt twice the convective limit. V is integrated by the RKC stages of
    tiseg.solver.timestepping.rkc (in increment form, ViscousSubstep.viscous_stage) with as many
    stages as the viscous spectral radius asks for over dt: s = stages_for(dt rho_visc), at
    least 2. Two half steps with a V of dt/2 each (x y V | V y x) cost two stability passes
    and 2 s(dt/2) viscous stages where this costs one pass and s(dt) ~ sqrt(2) s(dt/2) stages
    (benchmarks/split_fingers/README.md). ``rho`` given to `plan` is the viscous (+
    friction, zero when projected) stiffness alone: the sweeps need no share of it. V uses
    slots 0-3 (Y0, F0 and two stages).

    ``stages`` counts the sweeps, ``dims`` (2, or 1 in 1D) or twice that with viscosity,
    plus the viscous stages. Each sweep moves a wet front by at most one cell, as a
    Runge-Kutta stage does (the simulation's active range relies on it); V moves no mass, and
    its stages only widen that range."""

    name = "hancock"
    split = True
    slots = 1
    order = 2
    # a cell at rest between cells at rest exchanges no mass with them (the face rules of
    # the step's rest mask), gets no viscous force (its neighbours' velocities are its own)
    # and ends the step projected to rest: its h keeps its bits
    keeps_rest = True

    def __init__(self, dims: int = 2, viscous: bool = False, max_stages: int = 200):
        if dims not in (1, 2):
            raise InputError(f"dims={dims!r}: the split step sweeps 1 or 2 directions")
        self.dims = self.stages = dims
        self.viscous = bool(viscous)
        self.max_stages = max(2, int(max_stages))
        if self.viscous:
            self.slots = 4

    @property
    def halves(self) -> int:
        """Half steps of sweeps per step: 2 with viscosity (around V), else 1."""
        return 2 if self.viscous else 1

    @property
    def sweeps(self) -> int:
        """Sweeps per step: one per direction and half step."""
        return self.halves * self.dims

    def plan(self, dt_cfl, rho, dt_max, stages=None):
        if not self.viscous:
            if stages is not None and stages != self.stages:
                raise InputError(
                    f"stages={stages!r}: {self.name} always takes {self.stages} sweeps"
                )
            return min(dt_cfl, dt_max), self.stages
        # two halves, each sweep at most the convective limit
        dt = min(self.halves * dt_cfl, dt_max)
        if stages is not None:
            if not (isinstance(stages, int) and stages >= self.sweeps + 2):
                raise InputError(
                    f"stages={stages!r}: {self.name} with viscosity takes {self.sweeps} "
                    "sweeps and at least 2 viscous stages"
                )
            return dt, stages
        s = stages_for(dt * rho)
        if s > self.max_stages:
            # the stage cap binds: shorten the step so that dt rho fits beta(max_stages)
            s = self.max_stages
            dt = min(dt, ((s - 1) ** 2 - 1) / (1.54 * rho))
        return dt, self.sweeps + s

    def step(self, op, t, dt, stages):
        dirs = (0,) if self.dims == 1 else (0, 1)
        if not self.viscous:
            if self.index % 2:  # y, x on odd steps
                dirs = dirs[::-1]
            for k, d in enumerate(dirs):
                op.sweep(d, t, dt, first=k == 0, last=k == len(dirs) - 1)
            return
        self._pair(op, t, dt, dirs, lambda: viscous_substep(op, t, dt, stages - self.sweeps))

    def step_members(self, op, t, dt, stages):
        """`step` of each member of a batch (t, dt, stages one per member): the sweeps take
        every member's own dt; the viscous sub-step each member's own stage count."""
        counts = np.asarray([int(k) for k in stages])
        if not self.viscous:
            super().step_members(op, t, dt, counts)
            return
        dirs = (0,) if self.dims == 1 else (0, 1)
        self._pair(
            op, t, dt, dirs, lambda: viscous_substep_members(op, t, dt, counts - self.sweeps)
        )

    @staticmethod
    def _pair(op, t, dt, dirs, substep) -> None:
        """The two half steps of sweeps around the viscous sub-step ``substep()``."""
        half = 0.5 * dt
        # the first half from t: its first sweep takes the step's rest mask and speeds, its
        # last projects the friction over dt/2
        for k, d in enumerate(dirs):
            op.sweep(d, t, half, first=k == 0, last=k == len(dirs) - 1)
        # V over the whole step from t (its stage times span [t, t + dt]); it opens the
        # second half: the rest mask and speeds of the state it starts from
        substep()
        for k, d in enumerate(dirs[::-1]):
            op.sweep(d, t + half, half, first=False, last=k == len(dirs) - 1)


def viscous_substep(op, t: float, dt: float, s: int) -> None:
    """V over dt from t by s RKC stages (rkc_coefficients; RKC.step's recurrence written for
    the increments Y_j - Y0): slot 0 holds Y0 and then the result, slot 1 F0 = V(Y0), slots
    2 and 3 the last two stages. V opens the second half of Hancock's step (it takes the
    half's rest mask and speeds) and closes none, so it projects no friction."""
    mu_t1, coeffs, c = rkc_coefficients(s)
    Y0, A, B = 0, 2, 3
    op.viscous_stage(Y0, -1, A, (0.0, 0.0, mu_t1 * dt, 0.0), t, first=True)
    prev2, prev1 = Y0, A
    for j in range(2, s + 1):
        mu, nu, mu_t, gamma_t = coeffs[j - 2]
        dst = Y0 if j == s else (B if prev2 == Y0 else prev2)
        op.viscous_stage(
            prev1,
            prev2,
            dst,
            (mu, nu, mu_t * dt, gamma_t * dt),
            t + c[j - 1] * dt,
        )
        prev2, prev1 = prev1, dst


def viscous_substep_members(op, t, dt, stages) -> None:
    """viscous_substep of each member of a batch with its own stage count (``stages``, one
    per member; t and dt too): stage j is taken by the members with at least j stages, with
    their own coefficients, and a member's last stage writes its slot 0."""
    s, mu_t1, stage_numbers = member_tables(stages)
    Y0, A, B = 0, 2, 3
    op.viscous_stage(Y0, -1, A, (0.0, 0.0, mu_t1 * dt, 0.0), t, first=True)
    prev2, prev1 = Y0, A
    for j in range(2, int(s.max()) + 1):
        mu, nu, mu_t, gamma_t, c_prev = stage_numbers(j)
        common = B if prev2 == Y0 else prev2
        op.viscous_stage(
            prev1,
            prev2,
            np.where(s == j, Y0, common),
            (mu, nu, mu_t * dt, gamma_t * dt),
            t + c_prev * dt,
            live=s >= j,
        )
        prev2, prev1 = prev1, common
