"""Stopping a run that broke a bound or cannot advance, and saving what it was doing.

A collaborator of `tiseg.run.simulation.Simulation` (issue 49; a mixin before): the guard check
(`tiseg.run.guards`) and the stall check raise `SimulationError`; with a failure folder the
last good state and the offending one are saved there first. It receives the run it checks
and reads, besides the plan of a step (`tiseg.run.plan.StepPlan`), only what a run shows
anyone: its time and step count, its guard, its totals, budget and fields, its checkpoint
numbers and failure folder. The run's ``_guard`` stays the one entry every check goes through
(a test or a callback may wrap it)."""

from __future__ import annotations

import math
from pathlib import Path

from ..errors import TisegError
from . import checkpoint as _ckpt
from .guards import Violation
from .plan import StepPlan

MIN_STEP_FRACTION = 1e-9  # a step this much below the CFL limit: stiffness out of range


class SimulationError(TisegError):
    """The numerical solution broke a physical bound (NaN, h < 0, phi outside [0, 1], mass).

    ``violation``: the `tiseg.run.guards.Violation` (None for a collapsed step with no
    broken bound); ``files``: paths of the saved last-good and offending states (may be empty).
    """

    def __init__(self, message: str, violation: Violation | None = None, files=()):
        super().__init__(message)
        self.violation = violation
        self.files = tuple(files)


class FailureChecks:
    """The checks of a `tiseg.run.simulation.Simulation` that end a run."""

    def __init__(self, run):
        self.run = run

    def check_progress(self, p: StepPlan) -> None:
        """Stop a run that cannot get anywhere: a step too small to move the clock, or one
        shorter than MIN_STEP_FRACTION of the convective limit (RKC's stage cap or an
        explicit stepper's stability limit under a stiffness out of range, a huge flow.nu
        say): the message says which term."""
        run = self.run
        stab = p.stability
        small = (
            math.isfinite(p.dt_cfl) and p.dt < MIN_STEP_FRACTION * p.dt_cfl and not p.lands
        )  # a last step may be short: what was left
        if p.t_next > run.t and not small:
            return
        why = (
            f"time stalled: dt={p.dt:.3g} s does not advance t={run.t:.9g} s"
            if p.t_next <= run.t
            else f"dt={p.dt:.3g} s is {p.dt / p.dt_cfl:.2g} of the convective limit "
            f"{p.dt_cfl:.3g} s"
        )
        self.fail(
            None,
            f"{why} (step {run.stats.steps}); the stiffness is out of range: "
            f"viscous {stab.rho_visc:.3g} 1/s, friction {stab.rho_fric:.3g} 1/s "
            f"(flow.nu={run.scene.flow.nu!r}); check the scene's parameters",
        )

    def guard(self, full: bool = True) -> None:
        """One guard check (tiseg.run.guards); on success the state becomes the last good one.
        ``full``: with the mass balance (else the scan for broken bounds only)."""
        run = self.run
        v = run.guard.scan(run.t, run.stats.steps)
        if v is None and full:
            v = run.guard.check_mass(
                run.totals(), run.initial_totals, run.budget(), run.t, run.stats.steps
            )
        if v is not None:
            self.fail(v, v.message())
        if full:
            run.guard.keep(run.checkpoint_meta())

    def fail(self, violation: Violation | None, message: str):
        """Raise SimulationError; with a failure folder, save the last good and this state."""
        files = []
        if self.run.failure_dir is not None:
            try:
                files = self._save_failure(message)
            except OSError as exc:
                message += f" (could not save the failure states: {exc})"
        if files:
            good = self.run.guard.good_meta or {}
            message += (
                f"; last good state (t={good.get('t', float('nan')):.9g} s, step "
                f"{good.get('steps', '?')}) and the offending state saved in "
                f"{files[0].parent}/"
            )
        raise SimulationError(message, violation, files)

    def _save_failure(self, message: str) -> list[Path]:
        run = self.run
        d = Path(run.failure_dir)
        files = []
        good = run.guard.last_good()
        if good is not None:
            q, bud, meta = good
            files.append(
                _ckpt.write_npz_atomic(
                    d / "last_good.npz",
                    _ckpt.state_arrays(run, q=q, budget=bud, meta=meta, reason=message),
                )
            )
        files.append(
            _ckpt.write_npz_atomic(
                d / "offending.npz", _ckpt.state_arrays(run, reason=message, **run.fields())
            )
        )
        return files
