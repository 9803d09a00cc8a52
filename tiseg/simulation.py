"""The run loop: a scene, its Taichi operator, a stepper, and callbacks on a schedule.

Each step measures the wave speeds and stiffness of the current state, asks the stepper for
(dt, stages) from the convective CFL and the spectral radius, trims dt to land exactly on the
next output time, and advances. Output (NetCDF snapshots, diagnostics CSV), progress and the
non-finite guard run as callbacks at output times.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import backend
from .errors import InputError, TisegError
from .initial import initial_state
from .numerics.config import config_from_scene
from .timestepping import make_stepper


@dataclass
class StepInfo:
    t: float
    dt: float
    stages: int
    rhs_evals: int


class SimulationError(TisegError):
    """The numerical solution broke a physical bound (NaN, h < 0, phi outside [0, 1])."""


@dataclass
class RunStats:
    steps: int = 0
    stages: int = 0          # operator evaluations
    wall: float = 0.0
    history: list = field(default_factory=list)


class Simulation:
    """A scene being simulated. ``Simulation.from_scene("fingers", {"domain.resolution": 250})``."""

    def __init__(self, scene, arch: str | None = None, precision: str | None = None,
                 threads: int = 0, active_region: bool = True):
        from .numerics.operator import TaichiOperator

        self.scene = scene
        prec = precision or scene.numerics.precision
        if backend.is_initialised() and arch is None:
            st = backend.state()
            if st.precision != prec:
                backend.init(st.arch if st.arch == "cpu" else "gpu", prec, threads or st.threads)
        else:
            backend.init(arch or "cpu", prec, threads)
        self.backend = backend.state()
        self.cfg = config_from_scene(scene)
        self.layout = self.cfg.layout
        num = scene.numerics
        kw = {"max_stages": num.max_stages} if num.stepper == "rkc" else {}
        self.stepper = make_stepper(num.stepper, **kw)
        self.op = TaichiOperator(self.cfg, nslots=max(self.stepper.slots, 2))
        # Work only on the x range that can change (the wet region and a margin): exact,
        # because a dry cell away from wet ones has a zero right-hand side. Not with periodic x.
        self.active_region = active_region and scene.boundary.x_lo != "periodic"
        self._last_stages = 8
        self.t = 0.0
        self.stats = RunStats()
        self.reset()

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
        self.stats = RunStats()
        self.initial_totals = self.totals()

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
        inv = ax / sc.dx + (ay / sc.dy if not self.layout.is_1d else 0.0)
        # KT positivity limit dt <= C min(dx / a_x, dy / a_y) (Kurganov & Petrova 2007; C = 1/4
        # in 2D); the KT dissipation 2 (a_x/dx + a_y/dy) enters the spectral radius.
        rate = max(ax / sc.dx, (ay / sc.dy if not self.layout.is_1d else 0.0))
        dt_cfl = sc.numerics.cfl / rate if rate > 0 else math.inf
        rho = stab.rho_visc + stab.rho_fric + 2.0 * inv
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
        pad = stages + 3
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
            raise SimulationError(f"time step collapsed to dt={dt!r} at t={self.t:.6g} s")
        self.stepper.step(self.op, self.t, dt, stages)
        if t_target is not None and abs((self.t + dt) - t_target) <= 1e-12 * max(1.0, t_target):
            self.t = t_target
        else:
            self.t += dt
        evals = stages
        self.stats.steps += 1
        self.stats.stages += evals
        return StepInfo(self.t, dt, stages, evals)

    def advance(self, t_target: float, on_step=None) -> None:
        """Step until t == t_target exactly (the last step is trimmed)."""
        while self.t < t_target - 1e-12 * max(1.0, t_target):
            info = self.step(t_target)
            if on_step is not None:
                on_step(info)

    def check_state(self) -> None:
        """Stop with a clear message when the state holds NaN/Inf or h < 0 (guard)."""
        q = self.conserved()
        lay = self.layout
        bad = ~np.isfinite(q)
        if bad.any():
            c, i, j = np.argwhere(bad)[0]
            raise SimulationError(f"non-finite value in component {c} at cell (i={i}, j={j}) at "
                                  f"t={self.t:.6g} s after {self.stats.steps} steps")
        if (q[lay.H] < 0).any():
            i, j = np.argwhere(q[lay.H] < 0)[0]
            raise SimulationError(f"negative thickness {q[lay.H][i, j]:.3g} m at cell (i={i}, j={j}) "
                                  f"at t={self.t:.6g} s")

    # ------------------------------------------------------------------ run with output
    def run(self, out_dir=None, progress: bool = True, t_end: float | None = None,
            on_output=None) -> RunStats:
        """Run to t_end writing snapshots at the scene's output times into ``out_dir``
        (scene.toml, fields.nc, diagnostics.csv); without ``out_dir`` nothing is written.
        ``on_output(sim)``, if given, is called after each snapshot (e.g. to render a frame)."""
        from .output import DiagnosticsWriter, FieldsWriter, write_text_atomic

        sc = self.scene
        t_end = sc.t_end if t_end is None else t_end
        times = [t for t in sc.output_times if t <= t_end + 1e-12] or [t_end]
        writer = diag = None
        if out_dir is not None:
            out = Path(out_dir)
            try:
                out.mkdir(parents=True, exist_ok=True)
                write_text_atomic(out / "scene.toml", sc.to_toml())
            except OSError as exc:
                raise InputError(f"cannot write to output folder {str(out)!r}: {exc.strerror}")
            x, y = sc.domain.cell_centres()
            writer = FieldsWriter(out / "fields.nc", x, y,
                                  attrs={"scene": sc.to_toml(), "tiseg_arch": self.backend.arch,
                                         "tiseg_precision": self.backend.precision},
                                  fields=sc.fields,
                                  dtype="f8" if self.backend.precision == "f64" else "f4")
            diag = DiagnosticsWriter(out / "diagnostics.csv")
        bar = _progress(progress, t_end, sc.name)
        wall0 = _time.perf_counter()

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

        def on_step(info: StepInfo):
            record(info)
            if bar is not None:
                bar.update(info.t - bar.n)
                bar.set_postfix(steps=self.stats.steps, stages=info.stages, dt=f"{info.dt:.2e}",
                                refresh=False)

        try:
            if self.t <= times[0] + 1e-15:
                self._snapshot(writer, record, on_output)
            for t_out in times:
                if t_out <= self.t + 1e-12:
                    continue
                self.advance(t_out, on_step)
                self._snapshot(writer, record, on_output)
        finally:
            self.stats.wall += _time.perf_counter() - wall0
            if bar is not None:
                bar.close()
            if writer is not None:
                writer.close()
            if diag is not None:
                diag.close()
        return self.stats

    def _snapshot(self, writer, record, on_output=None) -> None:
        self.check_state()
        if writer is not None:
            writer.write(self.t, **self.fields())
        if on_output is not None:
            on_output(self)
        if self.stats.steps == 0:
            record(None)


def _progress(enabled: bool, total: float, name: str):
    if not enabled:
        return None
    from tqdm import tqdm
    return tqdm(total=total, unit="s", desc=f"{name}", bar_format=(
        "{desc}: {percentage:3.0f}%|{bar}| t={n:.3f}/{total:.3f} s [{elapsed}<{remaining}{postfix}]"))
