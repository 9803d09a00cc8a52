"""The dimensionally split MUSCL-Hancock step (tiseg.solver.numerics.split) as a stepper."""

from __future__ import annotations

from ...errors import InputError
from .base import Stepper, register


@register
class Hancock(Stepper):
    """One MUSCL-Hancock sweep per direction, in the order x, y on even steps and y, x on odd
    ones (the step's index comes from the simulation, ``index``, so a resumed run sweeps as
    the uninterrupted one did). The step is the convective limit itself: with step_rule
    "max" and numerics.cfl <= 1 (default 0.6) that is each sweep's Courant number. No stiff
    terms: the friction is the projected one, after the step's last sweep, and the scene
    refuses viscosity with this stepper, so the spectral radius plays no part.

    ``stages`` counts the sweeps: ``dims``, 2 (1 in 1D). Each moves a wet front by at most
    one cell, as a Runge-Kutta stage does (the simulation's active range relies on it)."""

    name = "hancock"
    split = True
    slots = 1
    order = 2
    # a cell at rest between cells at rest exchanges no mass with them (the face rules of
    # the step's rest mask) and ends the step projected to rest: its h keeps its bits
    keeps_rest = True

    def __init__(self, dims: int = 2):
        if dims not in (1, 2):
            raise InputError(f"dims={dims!r}: the split step sweeps 1 or 2 directions")
        self.stages = dims

    def plan(self, dt_cfl, rho, dt_max, stages=None):
        if stages is not None and stages != self.stages:
            raise InputError(f"stages={stages!r}: {self.name} always takes {self.stages} sweeps")
        return min(dt_cfl, dt_max), self.stages

    def step(self, op, t, dt, stages):
        dirs = (0,) if self.stages == 1 else ((0, 1) if self.index % 2 == 0 else (1, 0))
        for k, d in enumerate(dirs):
            op.sweep(d, t, dt, first=k == 0, last=k == len(dirs) - 1)
