"""The run loop: a scene, its Taichi operator, a stepper, and callbacks on a schedule.

Each step measures the wave speeds and stiffness of the current state, asks the stepper for
(dt, stages) from the convective CFL and the spectral radius, trims dt to land exactly on the
next output time, and advances. Output (NetCDF snapshots, diagnostics CSV), progress and the
non-finite guard run as callbacks at output times.

Guards (:mod:`tiseg.guards`): every ``check_every`` steps (default 10) and at every output time
the state is checked for NaN/Inf, h < 0 and 0 <= phi <= 1 on wet cells, and the mass balance;
a breach stops the run with a :class:`SimulationError` naming time, step, cell and field, and
(with an output folder) saves ``failure/last_good.npz`` and ``failure/offending.npz``.

Checkpoints (:mod:`tiseg.checkpoint`): with an output folder, ``checkpoint.npz`` is written at
every output time, per ``output.checkpoint_interval`` and per ``checkpoint_wall`` seconds;
:meth:`Simulation.resume` continues a killed run bit for bit.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import backend
from . import checkpoint as _ckpt
from .errors import InputError, TisegError
from .guards import StateGuard, Violation
from .initial import initial_state
from .numerics.config import config_from_scene
from .timestepping import stepper_for

# Cells beyond the wet region that the active x range keeps on top of one cell per RKC stage
# (the stencil's reach): the range stays exact (see TaichiOperator._combine).
ACTIVE_MARGIN = 3


def step_limits(ax: float, ay: float, rho_stiff: float, scene) -> tuple[float, float]:
    """(dt_cfl, rho): the rules every step is planned with, shared with tiseg.estimate.

    dt_cfl is the KT positivity limit dt <= C min(dx / a_x, dy / a_y) (Kurganov & Petrova
    2007; C = cfl = 1/4 in 2D), infinite when nothing moves; rho is the spectral radius the
    steppers plan with: the viscous + friction stiffness plus the KT dissipation
    2 (a_x/dx + a_y/dy) (NUMERICS finding 6)."""
    inv = ax / scene.dx + (ay / scene.dy if not scene.is_1d else 0.0)
    rate = max(ax / scene.dx, (ay / scene.dy if not scene.is_1d else 0.0))
    dt_cfl = scene.numerics.cfl / rate if rate > 0 else math.inf
    return dt_cfl, rho_stiff + 2.0 * inv


@dataclass
class StepInfo:
    t: float
    dt: float
    stages: int
    rhs_evals: int


class SimulationError(TisegError):
    """The numerical solution broke a physical bound (NaN, h < 0, phi outside [0, 1], mass).

    ``violation``: the :class:`tiseg.guards.Violation` (None for a collapsed step with no
    broken bound); ``files``: paths of the saved last-good and offending states (may be empty).
    """

    def __init__(self, message: str, violation: Violation | None = None, files=()):
        super().__init__(message)
        self.violation = violation
        self.files = tuple(files)


@dataclass
class RunStats:
    steps: int = 0
    stages: int = 0          # operator evaluations
    wall: float = 0.0
    history: list = field(default_factory=list)


class Simulation:
    """A scene being simulated. ``Simulation.from_scene("fingers", {"domain.resolution": 250})``."""

    def __init__(self, scene, arch: str | None = None, precision: str | None = None,
                 threads: int = 0, active_region: bool = True, check_every: int = 10,
                 mass_tol: float | None = None):
        """``check_every``: guard check every that many steps (0: only at output times);
        ``mass_tol``: relative mass-balance tolerance of the guard (see tiseg.guards)."""
        from .numerics.operator import TaichiOperator

        self.scene = scene
        prec = precision or scene.numerics.precision
        if backend.is_initialised() and arch is None:
            st = backend.state()
            if st.precision != prec:
                backend.init(backend.requested_arch(st.arch), prec, threads or st.threads)
        else:
            backend.init(arch or "cpu", prec, threads)
        self.backend = backend.state()
        self.cfg = config_from_scene(scene)
        self.layout = self.cfg.layout
        self.stepper = stepper_for(scene.numerics)
        self.op = TaichiOperator(self.cfg, nslots=max(self.stepper.slots, 2))
        # Work only on the x range that can change (the wet region and a margin): exact,
        # because a dry cell away from wet ones has a zero right-hand side. Not with periodic x.
        self.active_region = active_region and scene.boundary.x_lo != "periodic"
        self._last_stages = 8
        self.t = 0.0
        self.stats = RunStats()
        if not (isinstance(check_every, int) and check_every >= 0):
            raise InputError(f"check_every={check_every!r} must be an integer >= 0")
        self.check_every = check_every
        self.guard = StateGuard(self.op, h_ref=scene.flow.h0, mass_tol=mass_tol)
        self.failure_dir: Path | None = None     # where a guard failure saves its states
        self._io_counts = (0, 0)                 # (snapshots, diagnostics rows) written
        self.reset()

    @classmethod
    def resume(cls, run_dir, arch: str | None = None, threads: int = 0, **kwargs) -> "Simulation":
        """The simulation of a killed run folder at its last checkpoint; continue it with
        ``sim.run(out_dir=run_dir)`` (which appends to its fields.nc and diagnostics.csv)."""
        scene, ck = _ckpt.open_run_dir(run_dir)
        sim = cls(scene, arch=arch, precision=ck["precision"], threads=threads, **kwargs)
        _ckpt.restore(sim, ck)
        sim._resume = {"dir": Path(run_dir).resolve(), **{k: ck[k] for k in (
            "snapshots", "diag_rows", "wall", "next_sim")}}
        return sim

    @classmethod
    def from_scene(cls, scene, overrides=None, **kwargs) -> "Simulation":
        """Build from a Scene, a built-in scene name or a TOML path, with ``section.key`` overrides."""
        from .scene import Scene, load_scene
        if not isinstance(scene, Scene):
            scene = load_scene(scene, overrides)
        elif overrides:
            scene = scene.with_overrides(overrides)
        return cls(scene, **kwargs)

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        q0 = initial_state(self.scene, self.layout)
        self.op.set(0, q0)
        self.op.reset_budget()
        self.t = 0.0
        self._last_stages = 8
        self.stats = RunStats()
        self.initial_totals = self.totals()
        self._resume = None
        self.guard.keep(self.checkpoint_meta())

    def checkpoint_meta(self) -> dict:
        """The numbers besides slot 0 and the budget that a checkpoint needs (tiseg.checkpoint)."""
        snaps, rows = self._io_counts
        return {"t": self.t, "steps": self.stats.steps, "stages": self.stats.stages,
                "last_stages": self._last_stages, "wall": self.stats.wall,
                "initial_mass": self.initial_totals["mass"],
                "initial_small_mass": self.initial_totals["small_mass"],
                "snapshots": snaps, "diag_rows": rows}

    def restore_meta(self, ck: dict) -> None:
        """Inverse of :meth:`checkpoint_meta` (after slot 0 and the budget were restored)."""
        self.t = float(ck["t"])
        self.stats = RunStats(steps=int(ck["steps"]), stages=int(ck["stages"]),
                              wall=float(ck["wall"]))
        self._last_stages = int(ck["last_stages"])
        self.initial_totals = {"mass": float(ck["initial"][0]),
                               "small_mass": float(ck["initial"][1])}
        self._io_counts = (int(ck.get("snapshots", 0)), int(ck.get("diag_rows", 0)))
        self.guard.keep(self.checkpoint_meta())

    def conserved(self) -> np.ndarray:
        """Interior conserved variables (nc, nx, ny)."""
        ix, iy = self.layout.interior()
        return self.op.get(0)[:, ix, iy]

    def set_conserved(self, q_interior: np.ndarray) -> None:
        full = self.op.get(0)
        ix, iy = self.layout.interior()
        full[:, ix, iy] = q_interior
        self.op.set(0, full)

    def fields(self) -> dict[str, np.ndarray]:
        """Primitive fields h, u[, v][, phi] shaped (ny, nx) as in the output files.

        Velocities and phi are hu/h etc. where h > 0 and 0 on the empty chute."""
        lay = self.layout
        q = self.conserved()
        h = q[lay.H]
        safe = np.where(h > 0, h, 1.0)
        out = {"h": h.T.copy(), "u": np.where(h > 0, q[lay.HU] / safe, 0.0).T.copy()}
        if not lay.is_1d:
            out["v"] = np.where(h > 0, q[lay.HV] / safe, 0.0).T.copy()
        if lay.segregation:
            out["phi"] = np.clip(np.where(h > 0, q[lay.HPHI] / safe, 0.0), 0.0, 1.0).T.copy()
        return out

    def totals(self) -> dict[str, float]:
        """Total mass and small-particle mass [m^3] (per metre of width in 1D), summed in a
        fixed order on the device: deterministic for any thread count."""
        lay = self.layout
        sh, shphi = self.op.sums(0)
        cell = self.scene.dx * (self.scene.dy if not lay.is_1d else 1.0)
        return {"mass": sh * cell, "small_mass": shphi * cell if lay.segregation else float("nan")}

    def budget(self) -> dict[str, float]:
        """Mass and small-particle mass that entered through the boundaries since the start."""
        b = self.op.budget(0)
        scale = 1.0 if not self.layout.is_1d else 1.0 / self.scene.dy
        return {"mass_in": float((b[0] + b[2]) * scale), "small_mass_in": float((b[1] + b[3]) * scale)}

    # ------------------------------------------------------------------ stepping
    def plan_step(self, t_target: float | None = None) -> tuple[float, int, object]:
        """(dt, stages, stability numbers) for the next step from the current state."""
        sc = self.scene
        if self.active_region:
            extent = self.op.wet_extent(0, self.t)
            self._set_active(extent, self._last_stages)
        stab = self.op.stability(0, self.t)
        ax, ay = stab.ax, (stab.ay if not self.layout.is_1d else 0.0)
        ax = max(ax, self._inflow_speed())
        dt_cfl, rho = step_limits(ax, ay, stab.rho_stiff, sc)
        remaining = (t_target if t_target is not None else sc.t_end) - self.t
        dt_max = remaining if remaining > 0 else 0.0
        if not math.isfinite(dt_cfl) and rho == 0:
            dt_cfl = remaining
        dt, stages = self.stepper.plan(dt_cfl, rho, dt_max)
        self.last_stability = stab
        # avoid a sliver step just before an output time
        if 0 < remaining - dt < 1e-9 * max(1.0, remaining):
            dt = remaining
        if self.active_region and stages > self._last_stages:
            self._set_active(extent, stages)     # wet cells spread at most one cell per stage
        self._last_stages = stages
        return dt, stages, stab

    def _inflow_speed(self) -> float:
        """Wave speed of the full (un-ramped) inflow state: an empty chute being filled must
        not be allowed one huge step just because nothing inside moves yet."""
        c = self.cfg
        if c.bc[0] != "inflow" or self.t > c.inflow_stop:
            return 0.0
        a = abs(c.inflow_u) + math.sqrt(c.g_cos * c.inflow_h)
        if c.segregation:
            phi = c.inflow_phi
            a = max(a, abs(c.inflow_u * (1.0 - (1.0 - c.alpha) * (1.0 - 2.0 * phi))))
        return a

    def _set_active(self, extent: tuple[int, int], stages: int) -> None:
        lay = self.layout
        first, last = extent
        pad = stages + ACTIVE_MARGIN
        inflow = self.scene.boundary.x_lo == "inflow"
        if last < 0:                              # nothing wet: only an inflow can wet cells
            a, b = lay.gx, (lay.gx + pad if inflow else lay.gx)
        else:
            a = lay.gx if inflow else first - pad
            b = last + 1 + pad
        self.op.set_active(a, b)

    def step(self, t_target: float | None = None) -> StepInfo:
        self.op.check_alive()
        dt, stages, _ = self.plan_step(t_target)
        if not (dt > 0 and math.isfinite(dt)):
            # usually a NaN in the state: name it if the guard finds one
            self._guard(full=False)
            self._fail(None, f"time step collapsed to dt={dt!r} at t={self.t:.9g} s "
                             f"(step {self.stats.steps})")
        self.stepper.step(self.op, self.t, dt, stages)
        if t_target is not None and abs((self.t + dt) - t_target) <= 1e-12 * max(1.0, t_target):
            self.t = t_target
        else:
            self.t += dt
        evals = stages
        self.stats.steps += 1
        self.stats.stages += evals
        if self.check_every and self.stats.steps % self.check_every == 0:
            self._guard()
        return StepInfo(self.t, dt, stages, evals)

    def advance(self, t_target: float, on_step=None) -> None:
        """Step until t == t_target exactly (the last step is trimmed)."""
        while self.t < t_target - 1e-12 * max(1.0, t_target):
            info = self.step(t_target)
            if on_step is not None:
                on_step(info)

    def check_state(self) -> None:
        """Stop with a :class:`SimulationError` naming time, step, cell and field when the state
        holds NaN/Inf, h < 0, phi outside [0, 1] on a wet cell, or breaks the mass balance."""
        self._guard()

    def _guard(self, full: bool = True) -> None:
        """One guard check (tiseg.guards); on success the state becomes the last good one."""
        v = self.guard.scan(self.t, self.stats.steps)
        if v is None and full:
            v = self.guard.check_mass(self.totals(), self.initial_totals, self.budget(), self.t,
                                      self.stats.steps)
        if v is not None:
            self._fail(v, v.message())
        if full:
            self.guard.keep(self.checkpoint_meta())

    def _fail(self, violation: Violation | None, message: str):
        """Raise SimulationError; with a failure folder, save the last good and this state."""
        files = []
        if self.failure_dir is not None:
            try:
                files = self._save_failure(message)
            except OSError as exc:
                message += f" (could not save the failure states: {exc})"
        if files:
            good = self.guard.good_meta or {}
            message += (f"; last good state (t={good.get('t', float('nan')):.9g} s, step "
                        f"{good.get('steps', '?')}) and the offending state saved in "
                        f"{files[0].parent}/")
        raise SimulationError(message, violation, files)

    def _save_failure(self, message: str) -> list[Path]:
        d = Path(self.failure_dir)
        files = []
        good = self.guard.last_good()
        if good is not None:
            q, bud, meta = good
            files.append(_ckpt.write_npz_atomic(d / "last_good.npz", _ckpt.state_arrays(
                self, q=q, budget=bud, meta=meta, reason=message)))
        files.append(_ckpt.write_npz_atomic(d / "offending.npz", _ckpt.state_arrays(
            self, reason=message, **self.fields())))
        return files

    # ------------------------------------------------------------------ run with output
    def run(self, out_dir=None, progress: bool = True, t_end: float | None = None,
            on_output=None, checkpoint_wall: float | None = _ckpt.DEFAULT_WALL_INTERVAL) -> RunStats:
        """Run to t_end writing snapshots at the scene's output times into ``out_dir``
        (scene.toml, fields.nc, diagnostics.csv, checkpoint.npz); without ``out_dir`` nothing is
        written. ``on_output(sim)``, if given, is called after each snapshot (e.g. to render a
        frame). A simulation made by :meth:`resume` appends to its run folder.
        ``checkpoint_wall``: seconds of wall time between checkpoints at most (None: only at
        output times and per ``output.checkpoint_interval``)."""
        from .output import DiagnosticsWriter, FieldsWriter, write_text_atomic
        from .output.netcdf import FieldsFileError

        sc = self.scene
        t_end = sc.t_end if t_end is None else t_end
        times = [t for t in sc.output_times if t <= t_end + 1e-12]
        if not times or times[-1] < t_end - 1e-12 * max(1.0, t_end):
            times.append(t_end)               # an earlier end than the scene's is a snapshot too
        writer = diag = ck_path = None
        resume = self._resume
        if resume is not None and (out_dir is None or Path(out_dir).resolve() != resume["dir"]):
            resume = None                    # continuing elsewhere: a fresh set of files
        interval = sc.output.checkpoint_interval
        next_sim = math.inf
        if interval:
            next_sim = (math.floor(self.t / interval * (1 + 1e-12)) + 1) * interval
        if out_dir is not None:
            out = Path(out_dir)
            try:
                out.mkdir(parents=True, exist_ok=True)
                if resume is None:
                    write_text_atomic(out / "scene.toml", sc.to_toml())
                    writer = self._new_fields_writer(out / "fields.nc")
                    diag = DiagnosticsWriter(out / "diagnostics.csv")
                else:
                    diag = _ckpt.append_diagnostics(out / "diagnostics.csv", resume["diag_rows"])
                    try:
                        writer = FieldsWriter.append(out / "fields.nc", resume["snapshots"],
                                                     self.t)
                    except FieldsFileError as exc:
                        writer = self._salvage_fields(out, exc)
            except OSError as exc:
                if writer is not None:
                    writer.close()
                raise InputError(f"cannot write to output folder {str(out)!r}: "
                                 f"{exc.strerror or exc}") from None
            ck_path = out / _ckpt.CHECKPOINT_NAME
            self.failure_dir = out / "failure"
            if resume is not None and math.isfinite(resume["next_sim"]):
                next_sim = resume["next_sim"]
        self._resume = None
        bar = _progress(progress, t_end, sc.name, self.t)
        wall_start = _time.perf_counter()
        wall0 = wall_start - self.stats.wall      # the diagnostics' wall time continues
        last_ck = [_time.perf_counter()]

        def counts():
            self._io_counts = (writer.count if writer else 0, diag.rows if diag else 0)

        def save_checkpoint():
            nonlocal next_sim
            if interval and self.t >= next_sim * (1 - 1e-12):
                next_sim = (math.floor(self.t / interval * (1 + 1e-12)) + 1) * interval
            counts()
            self.stats.wall = _time.perf_counter() - wall0
            _ckpt.save(ck_path, self, next_sim=next_sim if math.isfinite(next_sim) else math.nan)
            last_ck[0] = _time.perf_counter()

        def record(info: StepInfo | None):
            """One diagnostics row: after every step, and at t = 0."""
            if diag is None:
                return
            tot = self.totals()
            stab = getattr(self, "last_stability", None)
            diag.write(time=self.t, dt=info.dt if info else 0.0, stages=info.stages if info else 0,
                       mass=tot["mass"], small_mass=tot["small_mass"],
                       max_speed=stab.max_speed if stab is not None else float("nan"),
                       wall_time=_time.perf_counter() - wall0)

        target = [times[0]]

        def on_step(info: StepInfo):
            record(info)
            if bar is not None:
                bar.update(info.t - bar.n)
                bar.set_postfix(steps=self.stats.steps, stages=info.stages, dt=f"{info.dt:.2e}",
                                refresh=False)
            # A step that lands on an output time is checkpointed after its snapshot (below),
            # so that a checkpoint never claims a time whose snapshot is not yet written.
            if ck_path is None or self.t >= target[0] - 1e-12 * max(1.0, target[0]):
                return
            due = self.t >= next_sim * (1 - 1e-12)
            if due or (checkpoint_wall is not None
                       and _time.perf_counter() - last_ck[0] >= checkpoint_wall):
                save_checkpoint()

        try:
            if self.t <= times[0] + 1e-15:
                self._snapshot(writer, record, on_output)
                counts()
            for t_out in times:
                if t_out <= self.t + 1e-12:
                    continue
                target[0] = t_out
                self.advance(t_out, on_step)
                self._snapshot(writer, record, on_output)
                if ck_path is not None:
                    save_checkpoint()
            if ck_path is not None and self.t >= sc.t_end - 1e-12 * max(1.0, sc.t_end):
                ck_path.unlink(missing_ok=True)      # finished: nothing left to resume
        finally:
            self.stats.wall = _time.perf_counter() - wall0
            counts()
            if bar is not None:
                bar.close()
            if writer is not None:
                writer.close()
            if diag is not None:
                diag.close()
        return self.stats

    def _new_fields_writer(self, path: Path):
        from .output import FieldsWriter
        x, y = self.scene.domain.cell_centres()
        return FieldsWriter(path, x, y, attrs={"scene": self.scene.to_toml(),
                                               "tiseg_arch": self.backend.arch,
                                               "tiseg_precision": self.backend.precision},
                            fields=self.scene.fields,
                            dtype="f8" if self.backend.precision == "f64" else "f4")

    def _salvage_fields(self, out: Path, exc: Exception):
        """Resume with a fields.nc that cannot be continued: keep it under another name and
        start a new one from the checkpoint on (the state itself is safe in the checkpoint)."""
        import sys
        old = out / "fields.nc"
        n = 1
        while (out / f"fields.damaged-{n}.nc").exists():
            n += 1
        kept = out / f"fields.damaged-{n}.nc"
        if old.exists():
            old.replace(kept)
        sys.stderr.write(f"tiseg: warning: {exc}; it was moved to {kept.name} and a new "
                         f"fields.nc starts at t={self.t:.9g} s\n")
        return self._new_fields_writer(old)

    def _snapshot(self, writer, record, on_output=None) -> None:
        self.check_state()
        if writer is not None:
            writer.write(self.t, **self.fields())
        if on_output is not None:
            on_output(self)
        if self.stats.steps == 0:
            record(None)


def _progress(enabled: bool, total: float, name: str, start: float = 0.0):
    if not enabled:
        return None
    from tqdm import tqdm
    return tqdm(total=total, initial=start, unit="s", desc=f"{name}", bar_format=(
        "{desc}: {percentage:3.0f}%|{bar}| t={n:.3f}/{total:.3f} s [{elapsed}<{remaining}{postfix}]"))
