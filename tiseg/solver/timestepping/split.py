"""The dimensionally split MUSCL-Hancock step (tiseg.solver.numerics.split) as a stepper."""

from __future__ import annotations

from ...errors import InputError
from .base import Stepper, register
from .rkc import rkc_coefficients, stages_for

VISCOUS = "v"  # the viscous sub-step among a step's sub-steps


@register
class Hancock(Stepper):
    """One MUSCL-Hancock sweep per direction, in the order x, y on even steps and y, x on odd
    ones (the step's index comes from the simulation, ``index``, so a resumed run sweeps as
    the uninterrupted one did). The step is the convective limit itself: with step_rule
    "max" and numerics.cfl <= 1 (default 0.6) that is each sweep's Courant number. The
    friction is the projected one, after the step's last sub-step.

    With viscosity (``viscous``) the viscous term of (6.2) is a third sub-step V, last on even
    steps (x, y, V) and first on odd ones (V, y, x), integrated over the whole step by the
    RKC stages of tiseg.solver.timestepping.rkc (in increment form,
    SplitSweeps.viscous_stage) with as many stages as the viscous spectral radius asks for:
    s = stages_for(dt rho_visc), at least 2, so the step stays the convective one.
    ``rho`` given to `plan` is then the viscous (+ friction, zero when projected) stiffness
    alone: the sweeps need no share of it. It uses slots 0-3 (Y0, F0 and two stages).

    ``stages`` counts the sweeps, ``dims`` (2, or 1 in 1D), plus the viscous stages. Each
    moves a wet front by at most one cell, as a Runge-Kutta stage does (the simulation's
    active range relies on it); V moves no mass, and its stages only widen that range."""

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

    def plan(self, dt_cfl, rho, dt_max, stages=None):
        dt = min(dt_cfl, dt_max)
        if not self.viscous:
            if stages is not None and stages != self.stages:
                raise InputError(
                    f"stages={stages!r}: {self.name} always takes {self.stages} sweeps"
                )
            return dt, self.stages
        if stages is not None:
            if not (isinstance(stages, int) and stages >= self.dims + 2):
                raise InputError(
                    f"stages={stages!r}: {self.name} with viscosity takes {self.dims} sweeps "
                    "and at least 2 viscous stages"
                )
            return dt, stages
        s = stages_for(dt * rho)
        if s > self.max_stages:
            # the stage cap binds: shorten the step so that dt rho fits beta(max_stages)
            s = self.max_stages
            dt = min(dt, ((s - 1) ** 2 - 1) / (1.54 * rho))
        return dt, self.dims + s

    def substeps(self) -> tuple:
        """This step's sub-steps in order: directions 0 (x), 1 (y) and VISCOUS."""
        even = self.index % 2 == 0
        dirs = (0,) if self.dims == 1 else ((0, 1) if even else (1, 0))
        if not self.viscous:
            return dirs
        return dirs + (VISCOUS,) if even else (VISCOUS,) + dirs

    def step(self, op, t, dt, stages):
        subs = self.substeps()
        for k, d in enumerate(subs):
            first, last = k == 0, k == len(subs) - 1
            if d == VISCOUS:
                viscous_substep(op, t, dt, stages - self.dims, first, last)
            else:
                op.sweep(d, t, dt, first=first, last=last)


def viscous_substep(op, t: float, dt: float, s: int, first: bool, last: bool) -> None:
    """V over dt from t by s RKC stages (rkc_coefficients; RKC.step's recurrence written for
    the increments Y_j - Y0): slot 0 holds Y0 and then the result, slot 1 F0 = V(Y0), slots
    2 and 3 the last two stages. ``first``, ``last``: V opens or closes the step."""
    mu_t1, coeffs, c = rkc_coefficients(s)
    Y0, A, B = 0, 2, 3
    op.viscous_stage(Y0, -1, A, (0.0, 0.0, mu_t1 * dt, 0.0), t, tau=dt, first=first)
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
            tau=dt,
            last=last,
        )
        prev2, prev1 = prev1, dst
