"""The dimensionally split MUSCL-Hancock step (tiseg.numerics.split) as a stepper."""

from __future__ import annotations

from ..errors import InputError
from .base import Stepper, register


@register
class Hancock(Stepper):
    """One MUSCL-Hancock sweep per direction, in the order x, y on even steps and y, x on odd
    ones (the step's index comes from the simulation, ``index``, so a resumed run sweeps as
    the uninterrupted one did). The step is the convective limit itself: with step_rule
    "max" and numerics.cfl <= 1 that is each sweep's Courant number. No stiff terms (the scene
    refuses viscosity and friction with this stepper), so the spectral radius plays no part.

    ``stages`` counts the sweeps, 2 (1 in 1D: the simulation's active range then is one
    cell wider than it needs); each moves a wet front by at most one cell."""

    name = "hancock"
    slots = 1
    order = 2
    stages = 2
    keeps_rest = True  # (no rest masks: friction is off)

    def plan(self, dt_cfl, rho, dt_max, stages=None):
        if stages is not None and stages != self.stages:
            raise InputError(f"stages={stages!r}: {self.name} always takes {self.stages} sweeps")
        return min(dt_cfl, dt_max), self.stages

    def step(self, op, t, dt, stages):
        dirs = (0,) if op.is_1d else ((0, 1) if self.index % 2 == 0 else (1, 0))
        for d in dirs:
            op.sweep(d, t, dt)
