"""The run loop: a scene, its Taichi operator, a stepper, and callbacks on schedules.

Each step measures the wave speeds and stiffness of the current state, asks the stepper for
(dt, stages) from the convective CFL and the spectral radius, and advances. Nothing but the end
of the run shortens a step: output, checkpoints, movies and the viewer are callbacks
(`tiseg.run.callbacks`) on schedules (`tiseg.run.schedules`) that observe the steps, and a
snapshot at an output time is interpolated between the two step states around it. Two runs
that differ only in what they write therefore take the same steps and end in the same bits.
Only ``t_end`` is landed on exactly; when less than two steps are left, the rest is split into
two equal steps, so no sliver step is taken.

Guards (`tiseg.run.guards`, the callback ``"guard"``): every ``check_every`` steps (default
10) and on every step that makes a snapshot the state is checked for NaN/Inf, h < 0 and 0 <= phi <= 1 on wet cells, and
the mass balance; a breach stops the run with a `SimulationError` naming time, step,
cell and field, and (with an output folder) saves ``failure/last_good.npz`` and
``failure/offending.npz``.

Checkpoints (`tiseg.run.checkpoint`, `tiseg.run.run_folder`): with an output folder,
``checkpoint.npz`` holds a step state, written after a step that crossed an output time (at
least ``checkpoint_spacing`` wall seconds apart), per ``output.checkpoint_interval``, per
``checkpoint_wall`` seconds and at the end of a run that stops early;
`Simulation.resume` continues a killed run bit for bit.

The Python API::

    sim = Simulation.from_scene("fingers", {"domain.resolution": 250, "time.t_end": 2})
    sim.add_callback(lambda snap: print(snap.t, snap.fields()["h"].max()),
                     TimeInterval(0.5), snapshot=True)
    sim.run(out_dir="runs/f250")

with the explicit mutators `Simulation.set_parameters`, `Simulation.set_state`
and `Simulation.reset`.
"""

from __future__ import annotations

import dataclasses
import math
import time as _time
from pathlib import Path

import numpy as np

from .. import backend
from . import checkpoint as _ckpt
from .callbacks import Callback, ProgressBar
from .dispatch import CallbackDispatch
from .failures import FailureChecks, SimulationError  # noqa: F401 (public name)
from .plan import (  # noqa: F401 (public names, shared with tiseg.apps.estimate)
    ACTIVE_MARGIN,
    RunStats,
    StepInfo,
    StepPlan,
    gravity_step,
    largest_acceleration,
    step_limits,
)
from .state_access import StateArrays
from ..errors import InputError, RunInterrupted
from .guards import StateGuard
from .gauges import Gauges
from .peaks import PeakFields, deposit
from ..setup.initial import initial_state
from .limits import check_memory
from ..solver.numerics.config import compiled_fields, config_from_scene
from .schedules import IterationInterval, Schedule, SpecifiedTimes
from ..setup.schema import compiled_keys
from ..setup.sections import SECTIONS
from ..solver.timestepping import stepper_for
from ..solver.numerics.operator import TaichiOperator
from ..solver.numerics.operator import StabilityNumbers
from .member_view import MemberOperator
from .run_folder import RunFolder


def state_slots(stepper) -> int:
    """The state slots a simulation holds: its stepper's (at least two) and two more, the
    state before a step that crosses a snapshot time (PREV) and the snapshot interpolated
    from it and the state after the step (SNAP)."""
    return max(stepper.slots, 2) + 2


class Simulation:
    """A scene being simulated. ``Simulation.from_scene("fingers", {"domain.resolution": 250})``.

    Its collaborators (issue 49): the operator ``op`` (`TaichiOperator`), the state as arrays
    ``arrays`` (`tiseg.run.state_access.StateArrays`, on the operator's state), the callbacks'
    ``dispatch`` (`tiseg.run.dispatch.CallbackDispatch`) and the ``failures`` that end a run
    (`tiseg.run.failures.FailureChecks`).

    Taichi is initialised on first use (``arch`` default cpu, the scene's precision). Once it
    is, a simulation asking for another precision, arch or thread count is an
    `InputError`: switching means ``tiseg.init(...)``, which invalidates every
    existing simulation, so it is never done behind the caller's back."""

    def __init__(
        self,
        scene,
        arch: str | None = None,
        precision: str | None = None,
        threads: int = 0,
        active_region: bool = True,
        check_every: int = 10,
        mass_tol: float | None = None,
        skip_rest: bool = True,
        operator: TaichiOperator | None = None,
        member: int = 0,
    ):
        """``operator``, ``member``: this simulation is member ``member`` of a batch, whose
        operator (built with several members for the scene's compiled options) it shares; it
        then steps with the batch (`tiseg.run.batch`), not alone.

        ``active_region``: work only on the x range that can change (exact); ``skip_rest``:
        leave out of it the regions held at rest (projected friction with a law with
        hysteresis and a stepper that keeps rest bit for bit, every one but SSPRK(10,4);
        exact for the same steps: False only to compare); ``check_every``: guard check every that
        many steps (0: only on steps that make a snapshot); ``mass_tol``: relative
        mass-balance tolerance of the guard (tiseg.run.guards)."""

        self.scene = scene
        prec = precision or scene.numerics.precision
        problem = backend.conflict(arch, prec, threads)
        if problem:
            raise InputError(problem)
        if not backend.is_initialised():
            backend.init(arch or "cpu", prec, threads)
        backend.check_field_room()
        self.backend = backend.state()
        self.cfg = config_from_scene(scene)
        self.layout = self.cfg.layout
        self.stepper = stepper_for(scene.numerics, is_1d=scene.is_1d, viscous=self.cfg.viscous)
        nslots = state_slots(self.stepper)  # the stepper's, PREV and SNAP
        self.PREV, self.SNAP = nslots - 2, nslots - 1
        self.member = int(member)
        if operator is None:
            if self.backend.arch == "cpu":  # before Taichi tries the allocation
                check_memory(self.layout, nslots, self.backend.precision)
            self.op = TaichiOperator(self.cfg, nslots=nslots)
        else:
            self.op = self._member_of(operator, nslots)
        if self.cfg.bed:  # the bed under the flow and its walls (tiseg.solver.numerics.bed)
            b, solid = scene.bed_arrays()
            self.op.set_bed(b, solid if self.cfg.solid else None)
        self.arrays = StateArrays(
            self.op.state, self.op.sums, self.op.budget, scene.dx, scene.dy, self.member
        )
        self.dispatch = CallbackDispatch(self)
        self.failures = FailureChecks(self)
        # Work only on the x range that can change (the wet region and a margin): exact,
        # because a dry cell away from wet ones has a zero right-hand side. Not with periodic x.
        self.active_region = active_region and scene.boundary.x_lo != "periodic"
        # and leave out the regions held at rest (RestRules._quiescent): exact as well
        # (for steppers that keep a resting cell's bits)
        self.op.skip_rest = (
            self.op.skip_rest and bool(skip_rest) and self.active_region and self.stepper.keeps_rest
        )
        # the run's observers read the operator's state (its fields, slots and ranges)
        self.guard = StateGuard(
            self.op.state, h_ref=scene.flow.h0, mass_tol=mass_tol, member=self.member
        )
        # the peak fields (tiseg.run.peaks), updated after every step; none when switched off
        self.peaks = PeakFields(self.op.state, self.member) if scene.output.peak_fields else None
        # the gauges (tiseg.run.gauges): read after every step by the run folder; none without
        self.gauges = self._make_gauges(scene)
        self.callbacks: dict[str, Callback] = {}
        self.check_every = check_every  # registers the guard callback
        self.failure_dir: Path | None = None  # where a guard failure saves its states
        self._io_counts = (0, 0)  # (snapshots, diagnostics rows) written
        # the gravity step limit of the scene it was computed for (plan; step_limits)
        self._dt_gravity, self._gravity_for = math.inf, None
        self._wall0: float | None = None  # perf_counter() at wall time 0 during run()
        self.reset()

    @classmethod
    def resume(cls, run_dir, arch: str | None = None, threads: int = 0, **kwargs) -> "Simulation":
        """The simulation of a killed run folder at its last checkpoint; continue it with
        ``sim.run(out_dir=run_dir)`` (which appends to its fields.nc and diagnostics.csv)."""
        scene, ck = _ckpt.open_run_dir(run_dir)
        sim = cls(scene, arch=arch, precision=ck["precision"], threads=threads, **kwargs)
        sim._continue(run_dir, ck)
        return sim

    def _continue(self, run_dir, ck: dict) -> None:
        """Put the checkpoint ``ck`` of the run folder ``run_dir`` in, so that the next run
        into that folder appends to its files (`resume`; a batch's members, `Batch.resume`)."""
        _ckpt.restore(self, ck)
        self._resume = {
            "dir": Path(run_dir).resolve(),
            **{k: ck[k] for k in ("snapshots", "diag_rows", "wall")},
        }

    @classmethod
    def from_scene(cls, scene, overrides=None, **kwargs) -> "Simulation":
        """Build from a Scene, a built-in scene name or a TOML path, with ``section.key`` overrides."""
        from ..setup.scene import Scene, load_scene

        if not isinstance(scene, Scene):
            scene = load_scene(scene, overrides)
        elif overrides:
            scene = scene.with_overrides(overrides)
        return cls(scene, **kwargs)

    def _member_of(self, operator: TaichiOperator, nslots: int) -> MemberOperator:
        """This simulation's view of the batch's ``operator``, with this scene's run-time
        numbers in its member's row: refused where the operator was built for other compiled
        options or another stepper."""
        if not isinstance(operator, TaichiOperator) or operator.state.M < 2:
            raise InputError("Simulation(operator=...): give an operator of several members")
        compiled = compiled_fields(compiled_keys(SECTIONS, "operator"))
        what = sorted(
            {v for k, v in compiled.items() if getattr(self.cfg, k) != getattr(operator.cfg, k)}
        )
        if what or operator.nslots != nslots:
            raise InputError(
                "Simulation(operator=...): the batch's operator was built for other "
                f"{', '.join(what) or 'stepper slots'}; its members must share them"
            )
        view = MemberOperator(operator, self.member)
        view.set_params(self.cfg)
        return view

    # ------------------------------------------------------------------ mutators
    def reset(self) -> None:
        """Back to the initial state of the scene (with the parameters as set) at t = 0."""
        q0 = initial_state(self.scene, self.layout)
        self.op.set(0, q0)
        self._io_counts = (0, 0)  # (snapshots, diagnostics rows) written
        self.op.reset_budget()
        self.t = 0.0
        self._last_stages = 8
        self.stats = RunStats()
        self.last_step: StepInfo | None = None
        self.last_stability = None
        self.initial_totals = self.totals()
        self._resume = None
        self.guard.keep(self.checkpoint_meta())
        if self.peaks is not None:
            self.peaks.start(self.t)

    def set_parameters(self, changes: dict | None = None, *, scene=None) -> None:
        """Change run-time parameters: ``section.key`` overrides of the scene (e.g.
        ``{"flow.nu": 0.02, "material.zeta_deg": 28, "inflow.h": 0.003}``), or a whole
        ``scene`` to take the values of. The scene and the operator change together; the state
        and the time stay. What the kernels were compiled for (grid, effects, boundaries,
        reconstruction, stepper, precision) cannot change: that is an `InputError`
        naming it (build a new Simulation instead)."""
        if scene is None:
            if not changes:
                return
            scene = self.scene.with_overrides(changes)
        old = self.scene
        cfg = config_from_scene(scene)
        if self.cfg.viscous and not cfg.viscous and scene.effects.viscosity:
            cfg = dataclasses.replace(cfg, viscous=True, nu=0.0)  # nu = 0: the same kernels
        # the operator's fields made from keys the schema says the kernels are compiled for
        compiled = compiled_fields(compiled_keys(SECTIONS, "operator"))
        what = sorted({v for k, v in compiled.items() if getattr(cfg, k) != getattr(self.cfg, k)})
        for full in compiled_keys(SECTIONS, "simulation"):  # built by the simulation itself
            section, key = full.split(".")
            if getattr(getattr(scene, section), key) != getattr(getattr(old, section), key):
                what.append(full)
        if what:
            why = (
                "; the viscous kernels were left out because flow.nu was 0 when the "
                "simulation was built"
                if "effects.viscosity" in what and not self.cfg.viscous and old.effects.viscosity
                else ""
            )
            raise InputError(
                f"set_parameters: this changes {', '.join(what)}, which the "
                f"simulation was compiled for{why}; build a new Simulation for that"
            )
        self.scene = scene
        self.cfg = cfg
        self.op.set_params(cfg)
        self.guard.set_params(h_ref=scene.flow.h0)  # h_min of the phi rule, the h tolerance

    # ------------------------------------------------------------------ callbacks
    def add_callback(
        self,
        func,
        schedule: Schedule | None = None,
        name: str | None = None,
        snapshot: bool = False,
        order: int = 0,
    ) -> Callback:
        """Register ``func`` to run on ``schedule`` after steps (see `tiseg.run.callbacks`),
        or a ready `Callback`; a callback of the same name is replaced. Returns it."""
        return self.dispatch.add(func, schedule, name, snapshot, order)

    def remove_callback(self, name: str) -> None:
        self.dispatch.remove(name)

    @property
    def check_every(self) -> int:
        """Steps between guard checks (0: only on steps that make a snapshot)."""
        return self._check_every

    @check_every.setter
    def check_every(self, n: int) -> None:
        self.dispatch.set_check_every(n)
        self._check_every = n

    # ------------------------------------------------------------------ checks
    def check_state(self) -> None:
        """Stop with a `SimulationError` naming time, step, cell and field when the state
        holds NaN/Inf, h < 0, phi outside [0, 1] on a wet cell, or breaks the mass balance."""
        self._guard()

    def _guard(self, full: bool = True) -> None:
        """One guard check (FailureChecks.guard): every check of the run goes through here."""
        self.failures.guard(full)

    # ------------------------------------------------------------------ state
    def set_state(self, h, u=None, v=None, phi=None) -> None:
        """Replace the state by primitive fields shaped (ny, nx) as `state` returns them
        (u, v default to 0, phi to the scene's phi0). The time stays; the mass balance starts
        afresh from this state (its mass is the new initial mass, the boundary budget 0), and
        so do the peak fields (tiseg.run.peaks: arrival at the current time where it is wet)."""
        q = self.arrays.from_primitives(h, u, v, phi, self.scene.flow.phi0)
        self.set_conserved(q)
        self.op.reset_budget()
        self.initial_totals = self.totals()
        self.guard.keep(self.checkpoint_meta())

    def state(self) -> dict[str, np.ndarray]:
        """The primitive fields ``h, u[, v][, phi]`` shaped (ny, nx) (as `fields`)."""
        return self.fields()

    def conserved(self, slot: int = 0) -> np.ndarray:
        """Interior conserved variables (nc, nx, ny)."""
        return self.arrays.conserved(slot)

    def set_conserved(self, q_interior: np.ndarray) -> None:
        """Replace the interior conserved variables (nc, nx, ny); the peak fields start again
        from this state (tiseg.run.peaks)."""
        self.arrays.set_conserved(q_interior)
        if self.peaks is not None:
            self.peaks.start(self.t)

    def fields(self, slot: int = 0) -> dict[str, np.ndarray]:
        """Primitive fields ``h, u[, v][, phi]`` shaped (ny, nx) as in the output files
        (StateArrays.fields)."""
        return self.arrays.fields(slot)

    def totals(self, slot: int = 0) -> dict[str, float]:
        """Total mass and small-particle mass [m^3] (per metre of width in 1D), deterministic
        for any thread count (StateArrays.totals)."""
        return self.arrays.totals(slot)

    def budget(self, slot: int = 0) -> dict[str, float]:
        """Mass and small-particle mass that entered through the boundaries since the start."""
        return self.arrays.budget(slot)

    def checkpoint_meta(self) -> dict:
        """The numbers besides slot 0 and the budget that a checkpoint needs (tiseg.run.checkpoint)."""
        snaps, rows = self._io_counts
        return {
            "t": self.t,
            "steps": self.stats.steps,
            "stages": self.stats.stages,
            "last_stages": self._last_stages,
            "wall": self.stats.wall,
            "initial_mass": self.initial_totals["mass"],
            "initial_small_mass": self.initial_totals["small_mass"],
            "snapshots": snaps,
            "diag_rows": rows,
        }

    def restore_meta(self, ck: dict) -> None:
        """Inverse of `checkpoint_meta` (after slot 0 and the budget were restored)."""
        self.t = float(ck["t"])
        self.stats = RunStats(
            steps=int(ck["steps"]), stages=int(ck["stages"]), wall=float(ck["wall"])
        )
        self._last_stages = int(ck["last_stages"])
        self.initial_totals = {
            "mass": float(ck["initial"][0]),
            "small_mass": float(ck["initial"][1]),
        }
        self._io_counts = (int(ck.get("snapshots", 0)), int(ck.get("diag_rows", 0)))
        self.guard.keep(self.checkpoint_meta())

    def peak_fields(self) -> dict:
        """The peak fields (tiseg.run.peaks) as float64 arrays (ny, nx), NaN where missing:
        ``h_max``, ``speed_max``, ``arrival_time`` up to the current step, and ``deposit_h``
        (and ``deposit_phi`` with segregation) of the current state. An InputError when the
        scene switched them off (``output.peak_fields = false``)."""
        if self.peaks is None:
            raise InputError(
                f"scene {self.scene.name!r} has output.peak_fields = false: this simulation "
                "keeps no peak fields"
            )
        return {**self.peaks.arrays(), **deposit(self.fields(), self.scene.numerics.h_min)}

    def _make_gauges(self, scene):
        """The gauges of ``[[output.gauges]]`` on this operator, or None (no field, no kernel)."""
        pts = [(g.name, g.x, g.y) for g in scene.output.gauges]
        if not pts:
            return None
        return Gauges(self.op.state, pts, scene.dx, scene.dy, scene.numerics.h_min, self.member)

    def gauge_values(self) -> dict:
        """{gauge name: {quantity: value}} of the current state (tiseg.run.gauges): h, u, v,
        phi at each ``[[output.gauges]]`` point, interpolated bilinearly. An InputError when
        the scene has no gauges."""
        if self.gauges is None:
            raise InputError(f"scene {self.scene.name!r} has no [[output.gauges]]")
        vals = self.gauges.read()
        return {
            n: {q: float(a[i]) for q, a in vals.items()} for i, n in enumerate(self.gauges.names)
        }

    def wall_time(self) -> float:
        """Cumulative wall time of the run [s] (continues across resumes)."""
        if self._wall0 is None:
            return self.stats.wall
        return _time.perf_counter() - self._wall0

    # ------------------------------------------------------------------ stepping
    def _stop_time(self, t_stop: float | None) -> float:
        """Where the next step must not go past: t_stop, else the scene's t_end while it is
        ahead, else nowhere (a viewer running on)."""
        if t_stop is not None:
            return float(t_stop)
        t_end = self.scene.t_end
        return t_end if self.t < t_end - 1e-12 * max(1.0, t_end) else math.inf

    def plan(self, t_stop: float | None = None, stages: int | None = None) -> StepPlan:
        """The next step from the current state (sets the operator's active range for it).

        ``t_stop``: a time the step must land on rather than pass (default the scene's
        t_end); ``stages``: a fixed stage count (benchmarks), else the stiffness decides.
        Plan once per step: a second plan finds the rest mask the first one took (without
        the static friction's hold) and computes resting regions it could skip (correct,
        only slower)."""
        return self._plan_step(self._plan_range(), t_stop, stages)

    def _plan_range(self):
        """The first part of `plan`: the wet scan and the x range it gives the step (None
        without an active region). In a batch the scan is the batch's (`tiseg.run.batch`)."""
        if not self.active_region:
            return None
        extent = self.op.wet_extent(0, self.t)
        self._set_active(extent, self._last_stages)
        return extent

    def _plan_step(self, extent, t_stop: float | None, stages: int | None) -> StepPlan:
        """The rest of `plan`: the stability pass (in a batch the batch's) and the step."""
        sc = self.scene
        if self.active_region and self.op.active[0] == self.op.active[1]:
            # nothing can change (every cell is a dry film or held at rest, far from any
            # other): no stability limit, the step goes to the stop time at no cost

            stab = StabilityNumbers(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        else:
            stab = self.op.stability(0, self.t)
        ax, ay = stab.ax, (stab.ay if not self.layout.is_1d else 0.0)
        rate_local = stab.rate_local
        a_in = self._inflow_speed()
        if a_in > ax:  # the inlet's face speed, which the stability pass does not see
            ax = a_in
            if rate_local is not None:
                rate_local = max(rate_local, a_in / sc.dx + ay / sc.dy)
        if self._gravity_for is not sc:  # (scenes are immutable: a new one, a new limit)
            self._dt_gravity, self._gravity_for = gravity_step(sc), sc
        dt_cfl, rho = step_limits(ax, ay, stab.rho_stiff, sc, rate_local, self._dt_gravity)
        stop = self._stop_time(t_stop)
        remaining = max(stop - self.t, 0.0)
        if not math.isfinite(dt_cfl) and rho == 0:  # nothing moves and nothing is stiff
            dt_cfl = remaining if math.isfinite(remaining) else 1.0
        if self.stepper.split:
            # the sweeps need no spectral radius; a viscous sub-step takes its stages from
            # the viscous stiffness alone (Hancock.plan). The friction is projected, so
            # rho_fric is that of stiff source terms, which the x sweep takes as one Euler
            # step: dt rho_fric <= cfl keeps it stable and its sign
            rho = stab.rho_visc
            if stab.rho_fric > 0.0:
                dt_cfl = min(dt_cfl, sc.numerics.cfl / stab.rho_fric)
        dt, s = self.stepper.plan(dt_cfl, rho, math.inf, stages)
        t_next = self.t + dt
        if remaining <= dt * (1.0 + 1e-9):  # the last step lands on the stop
            dt, s = self.stepper.plan(dt_cfl, rho, remaining, stages)
            if remaining - dt <= 1e-9 * remaining:  # (an RKC stage cap may trim it)
                dt, t_next = remaining, stop
            else:
                t_next = self.t + dt
        elif remaining < 2.0 * dt:  # two equal steps rather than a sliver
            dt, s = self.stepper.plan(dt_cfl, rho, 0.5 * remaining, stages)
            t_next = self.t + dt
        self.last_stability = stab
        if self.active_region and s > self._last_stages:
            self._set_active(extent, s)  # wet cells spread at most one cell per stage
        self._last_stages = s
        return StepPlan(dt, s, stab, t_next, dt_cfl, t_next == stop)

    def _inflow_speed(self) -> float:
        """Wave speed of the full (un-ramped) inflow state: an empty chute being filled must
        not be allowed one huge step just because nothing inside moves yet."""
        c = self.cfg
        if not self.op.inflow_on(self.t):
            return 0.0
        a = abs(c.inflow_u) + math.sqrt(c.g_cos * c.inflow_h)
        if c.segregation:
            phi = c.inflow_phi
            a = max(a, abs(c.inflow_u * (1.0 - (1.0 - c.alpha) * (1.0 - 2.0 * phi))))
        return a

    def _set_active(self, extent: tuple[int, int, int, int], stages: int) -> None:
        """The x range the next step of ``stages`` stages works on, from the wet and the live
        extent (TaichiOperator.wet_extent). Wet cells spread at most one cell per stage, so
        cells further than ``stages`` + ACTIVE_MARGIN from every wet one are dry films that
        stay so. Where resting regions are skipped (a law with hysteresis, projected
        friction), a change travels at most 2 cells per stage (the stencil's reach), so cells
        further than 2 ``stages`` + ACTIVE_MARGIN from every live one keep their bits; the
        step works on the intersection of the two ranges, which is empty when nothing moves."""
        lay = self.layout
        first, last, lfirst, llast = extent
        pad = stages + ACTIVE_MARGIN
        inflow = self.scene.boundary.x_lo == "inflow"
        if last < 0:  # nothing wet: only an inflow can wet cells
            a, b = lay.gx, (lay.gx + pad if inflow else lay.gx)
        else:
            a = lay.gx if inflow else first - pad
            b = last + 1 + pad
        wet = (a, b)
        if self.op.skip_rest:
            lpad = 2 * stages + ACTIVE_MARGIN
            # an inflow that still runs changes the inlet's ghost cells: never skipped
            inlet = self.op.inflow_on(self.t)
            if llast < 0:
                la, lb = (lay.gx, lay.gx + lpad) if inlet else (a, a)
            else:
                la = lay.gx if inlet else lfirst - lpad
                lb = llast + 1 + lpad
            a, b = max(a, la), min(b, lb)  # (set_active makes an empty range of b < a)
        self.op.set_active(a, b, wet)

    def step(self, t_stop: float | None = None, stages: int | None = None) -> StepInfo:
        """One time step, then the callbacks that fell due. ``t_stop``: land there instead of
        passing it (default the scene's t_end, nothing once it is passed); ``stages``: a fixed
        stage count (benchmarks)."""
        self.op.check_alive()
        if t_stop is not None and not float(t_stop) > self.t:
            raise InputError(
                f"step(t_stop={t_stop!r}): the simulation is already at "
                f"t={self.t!r} s; give a later stop time"
            )
        p = self.plan(t_stop, stages)
        pending = self._step_begin(p)
        self.stepper.step(self.op, self.t, p.dt, p.stages)
        return self._step_end(p, pending)

    def _step_begin(self, p: StepPlan) -> list:
        """What comes before the step of plan ``p``: its checks, and the state before it
        kept where a snapshot falls inside it. Returns the pending snapshots."""
        dt = p.dt
        if not (dt > 0 and math.isfinite(dt)):
            # usually a NaN in the state: name it if the guard finds one
            self._guard(full=False)
            self.failures.fail(
                None,
                f"time step collapsed to dt={dt!r} at t={self.t:.9g} s (step {self.stats.steps})",
            )
        t0, t1 = self.t, p.t_next
        self.failures.check_progress(p)
        pending = self.dispatch.pending_snapshots(t0, t1)
        if any(tk < t1 for tk, _ in pending):
            self.op.blend(self.PREV, 0, 0, 0.0)  # keep the state before the step
        self.stepper.index = self.stats.steps  # (a split step's sweep order follows it)
        return pending

    def _step_end(self, p: StepPlan, pending: list, peaks_done: bool = False) -> StepInfo:
        """What comes after the step of plan ``p``: the time, the peaks (unless a batch
        folded them in for all its members: ``peaks_done``), the statistics and the
        callbacks that fell due."""
        t0, t1, s = self.t, p.t_next, p.stages
        self.t = t1
        if self.peaks is not None and not peaks_done:
            self.peaks.update(t1)  # observes the step state; writes nothing the steps read
        self.stats.steps += 1
        self.stats.stages += s
        self.last_step = StepInfo(t1, p.dt, s, s)
        self.dispatch.after_step(t0, t1, pending)
        return self.last_step

    def advance(self, t_target: float, on_step=None) -> None:
        """Step until t == t_target exactly (the last step lands there)."""
        while self.t < t_target - 1e-12 * max(1.0, t_target):
            info = self.step(t_target)
            if on_step is not None:
                on_step(info)

    # ------------------------------------------------------------------ the loop
    def output_times(self, t_end: float | None = None) -> list[float]:
        """The scene's output times up to t_end (default the scene's), t_end included."""
        t_end = self.scene.t_end if t_end is None else float(t_end)
        times = [min(t, t_end) for t in self.scene.output_times if t <= t_end * (1 + 1e-12)]
        if not times or times[-1] < t_end - 1e-12 * max(1.0, t_end):
            times.append(t_end)  # an earlier end than the scene's is a snapshot too
        return sorted(set(times))

    def run(
        self,
        out_dir=None,
        progress: bool = True,
        t_end: float | None = None,
        on_output=None,
        checkpoint_wall: float | None = _ckpt.DEFAULT_WALL_INTERVAL,
        checkpoint_spacing: float = _ckpt.DEFAULT_SPACING,
        callbacks=(),
        overwrite: bool = False,
        signals: bool = False,
    ) -> RunStats:
        """Step to t_end (default the scene's) with the registered callbacks.

        * with ``out_dir``: scene.toml, fields.nc at the output times, diagnostics.csv (a row
          per step), checkpoint.npz (`tiseg.run.run_folder`); a simulation made by
          `resume` appends to its run folder;
        * ``on_output(snap)``: a snapshot callback at the output times (e.g. a movie frame);
        * ``callbacks``: more `tiseg.run.callbacks.Callback` objects;
        * ``progress``: a progress bar.

        ``checkpoint_wall``: seconds of wall time between checkpoints at most (None: only at
        output times and per ``output.checkpoint_interval``); ``checkpoint_spacing``: seconds
        of wall time at least between the checkpoints of output times (0: one at every output
        time). None of this changes the steps.
        A fresh run refuses an ``out_dir`` that holds other files or another run unless
        ``overwrite`` (`tiseg.run.run_folder`). ``signals``: SIGTERM and SIGINT stop
        the run at the end of the current step, with a checkpoint when there is a folder, by
        raising `RunInterrupted` (the command line exits 143 / 130)."""

        session = RunSession(
            self,
            out_dir,
            progress,
            t_end,
            on_output,
            checkpoint_wall,
            checkpoint_spacing,
            callbacks,
            overwrite,
            signals,
        )
        try:
            session.open()
            while not session.done():
                self.step(session.t_end)
            session.finish()
        except _StopNow as now:  # a second signal: as RunInterrupted, out of Taichi's reach
            raise now.error from None
        finally:
            session.close()
        return self.stats


class RunSession:
    """A run of `Simulation.run` with its output folder, progress bar, signal handlers and
    callbacks: checked when made (everything that can be refused is refused before the folder
    is touched), then opened (`open`), stepped by its simulation until `done`, finished
    (`finish`) and closed whatever happened (`close`). A batch (`tiseg.run.batch`) keeps one for each member."""

    def __init__(
        self,
        sim,
        out_dir=None,
        progress: bool = True,
        t_end: float | None = None,
        on_output=None,
        checkpoint_wall: float | None = _ckpt.DEFAULT_WALL_INTERVAL,
        checkpoint_spacing: float = _ckpt.DEFAULT_SPACING,
        callbacks=(),
        overwrite: bool = False,
        signals: bool = False,
    ):
        self.sim = sim
        t_end = sim.scene.t_end if t_end is None else float(t_end)
        if not (math.isfinite(t_end) and t_end >= 0):
            raise InputError(f"run(t_end={t_end!r}): give a finite time >= 0")
        self.t_end = t_end
        self.times = sim.output_times(t_end)
        extra = []
        if on_output is not None:
            extra.append(
                Callback(on_output, SpecifiedTimes(self.times), name="on_output", snapshot=True)
            )
        for cb in callbacks:
            if not isinstance(cb, Callback):
                raise InputError(
                    f"run(callbacks=...): {cb!r} is not a tiseg.run.callbacks.Callback "
                    "(wrap a function as Callback(func, schedule))"
                )
            extra.append(cb)
        if checkpoint_wall is not None and not (checkpoint_wall >= 0):
            raise InputError(f"checkpoint_wall={checkpoint_wall!r} must be a number >= 0")
        if not (isinstance(checkpoint_spacing, (int, float)) and checkpoint_spacing >= 0):
            raise InputError(f"checkpoint_spacing={checkpoint_spacing!r} must be a number >= 0")
        resume = sim._resume
        if resume is not None and (out_dir is None or Path(out_dir).resolve() != resume["dir"]):
            resume = None  # continuing elsewhere: a fresh set of files
        self.extra, self.resume = extra, resume
        self.out_dir, self.progress, self.signals = out_dir, progress, signals
        self.checkpoint_wall, self.checkpoint_spacing = checkpoint_wall, checkpoint_spacing
        self.overwrite = overwrite
        self.saved, self.failure_dir = dict(sim.callbacks), sim.failure_dir
        self.folder = self.bar = self.stop = None

    def open(self) -> None:
        """The folder, the callbacks on their schedules, the first check and snapshots."""
        sim, extra = self.sim, list(self.extra)
        if self.out_dir is not None:
            self.folder = folder = RunFolder(sim, self.out_dir, self.resume, self.overwrite)
            folder.checkpoint_spacing = float(self.checkpoint_spacing)
            sim._resume = None  # the files are open: what resume knew is used
            extra = list(folder.callbacks(self.times, self.checkpoint_wall)) + extra
        if self.progress:
            self.bar = ProgressBar(self.t_end, sim.scene.name, sim.t)
            extra.append(Callback(self.bar, IterationInterval(1), name="progress"))
        if self.signals:
            self.stop = _SignalStop(sim, self.folder, self.t_end)
            extra.append(
                Callback(self.stop, IterationInterval(1), name="signals", order=1000, checked=True)
            )
        for cb in extra:
            sim.callbacks[f"run:{cb.name}"] = cb
        for cb in sim.callbacks.values():
            cb.schedule.start()
        sim._wall0 = _time.perf_counter() - sim.stats.wall
        sim._guard()
        if self.resume is None:
            sim.dispatch.initial_snapshots()
            if self.folder is not None:
                self.folder.start()

    def done(self) -> bool:
        """Whether the simulation has reached the run's end time."""
        return not self.sim.t < self.t_end - 1e-12 * max(1.0, self.t_end)

    def finish(self) -> None:
        """The end of a run that reached its end time: the folder's last writes."""
        folder = self.folder
        if folder is not None:
            folder.finish()
            if folder.checkpoint_path.is_file():  # stopped before the scene's end:
                self.sim._resume = folder.resume_info()  # a later run() there continues it

    def close(self) -> None:
        """Whatever happened: the handlers, the wall time, the callbacks and the files."""
        sim = self.sim
        if self.stop is not None:
            self.stop.restore()
        if sim._wall0 is not None:
            sim.stats.wall = sim.wall_time()
        sim._wall0 = None
        sim.callbacks = self.saved
        sim.failure_dir = self.failure_dir
        if self.bar is not None:
            self.bar.close()
        if self.folder is not None:
            self.folder.close()


class _StopNow(BaseException):
    """A second SIGTERM / SIGINT on its way out of the step (and of Taichi's compiler, which
    catches every Exception); `Simulation.run` raises its `RunInterrupted` in its place."""

    def __init__(self, error: RunInterrupted):
        super().__init__(str(error))
        self.error = error


class _SignalStop:
    """SIGTERM / SIGINT handlers that let the current step finish; as the last callback of
    that step it writes a checkpoint (with a run folder) and raises RunInterrupted."""

    def __init__(self, sim, folder, t_end: float):
        import signal
        import threading

        self.sim, self.folder, self.signum, self.t_end = sim, folder, None, t_end
        self.old = {}
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGTERM, signal.SIGINT):
                self.old[sig] = signal.signal(sig, self._handle)

    def _handle(self, signum, frame):
        import signal

        if self.signum is not None:  # a second signal: stop now, mid-step
            # not an Exception while it unwinds: Taichi wraps any Exception raised while it
            # compiles a kernel into a TaichiCompilationError (a traceback, exit status 1)
            raise _StopNow(
                RunInterrupted(
                    f"stopped at once by a second {signal.Signals(signum).name}; "
                    "the last checkpoint (if any) is kept",
                    signum,
                )
            )
        self.signum = signum

    def __call__(self, sim) -> None:
        if self.signum is None or sim.t >= self.t_end - 1e-12 * max(1.0, self.t_end):
            return  # the last step: the run simply finishes
        import signal

        name = signal.Signals(self.signum).name
        where = f"at t = {sim.t:.6g} s (step {sim.stats.steps})"
        if self.folder is None:
            raise RunInterrupted(f"stopped by {name} {where}; nothing was being saved", self.signum)
        self.folder.save_checkpoint(sim)
        raise RunInterrupted(
            f"stopped by {name} {where}; checkpoint written: continue with "
            f"`tiseg run --resume {self.folder.path}`",
            self.signum,
        )

    def restore(self) -> None:
        import signal

        for sig, handler in self.old.items():
            signal.signal(sig, handler)
        self.old = {}


__all__ = [
    "Simulation",
    "SimulationError",
    "RunInterrupted",
    "StepInfo",
    "StepPlan",
    "RunStats",
    "step_limits",
    "gravity_step",
    "ACTIVE_MARGIN",
]
