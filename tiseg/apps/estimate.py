"""Run-time estimate before running: steps, RKC stages and wall time of a scene on this machine.

``tiseg estimate SCENE [--set ...]`` and ``tiseg run SCENE --estimate`` predict a run from two
ingredients:

1. **A flow model** (`flow_model`): from the scene's steady state (h0, u0, phi0) and its
   set-up, the largest wave speeds a_x(t), a_y(t), the largest thickness h_max(t) (viscous
   stiffness), the slowest wet speed u_slow(t) (friction stiffness) and the wet x range (the
   active region the operator computes) as functions of time. The step and stage count then
   follow from exactly the rules the run uses (`Simulation.plan` and the stepper's
   ``plan``, `tiseg.run.simulation.step_limits`): dt = cfl / max(a_x/dx, a_y/dy), or
   cfl / (a_x/dx + a_y/dy) with ``numerics.step_rule = "sum"`` (also for ``"local"``, whose
   per-cell rate the model does not know: an upper bound on its steps), times an SSP stepper's SSP
   coefficient, and, for RKC, s from dt * rho with
   rho = max(rho_visc, rho_fric) + 2 (a_x/dx + a_y/dy), rho_visc the Gershgorin bound of the
   viscous term for uniform h_max and rho_fric = g cos(zeta) tan(zeta) / u_slow (the run bounds
   the two terms together cell by cell, and they peak in different cells: viscosity in thick
   channels, friction in slow thin levees, so the larger one stands for both). A split
   stepper's step is its sweeps and, with viscosity, s viscous stages from dt * rho_visc alone
   (the counts the run reports); its calibrated stage is a sweep, and the viscous stages are
   priced inside the measured per-step work. Output times do
   not shorten steps (snapshots are interpolated, `tiseg.run.callbacks`): the steps are
   counted over [0, t_end] in one piece, whose last step lands on t_end.

   For an inflow into an empty chute with segregation-mobility feedback (the fingers scene) the
   flow goes through three stages, with numbers taken from the paper (figure 12) and checked on
   runs at 100-250 cells/m (see benchmarks/README.md):

   * t = 0: the inflow state, a = u0 + sqrt(g' h0) (g' = g cos zeta), or the segregation speed
     u0 (1 - G'(phi0)) if larger;
   * the coarse-rich head thickens to about HEAD_THICKNESS h0 = 2.5 h0 by the onset of fingering
     (T_ONSET = 5.1 s, the paper's "becomes unstable around 5.1 s"): a -> u0 + sqrt(2.5 g' h0);
   * fingers form by T_FORMED = 7.5 s (figure 12's last panel): the channels run at about
     2 u0 on h ~ 2 h0, a -> 2 u0 + sqrt(2 g' h0) (or the segregation speed there), and
     near-stationary levees (u_slow ~ u0/30) make friction the stiffest term;
   * the front advances at about FRONT_SPEED u0 = 0.8 u0 (measured; a monodisperse front runs
     at u0), and the active x range is [0, x_front + the margin of stages + 3 cells].

   Uniform flows keep their state (a = u0 + c0); a dam break or a released block spreads with
   the front speed 2 sqrt(g' h) less 2 sqrt(g' h_min) (the tip where fluxes are cut off), plus
   the acceleration g (sin zeta - mu cos zeta) t on a slope. These are estimates for planning,
   not bounds: a scene far from these set-ups (a finite release after its inflow stops, fingers
   at other parameters) will differ.

2. **A calibration in this process** (`calibrate`): the scene's own Simulation on its own
   grid, in a wet state (the uniform flow h0, u0, phi0 with noise) covering all of x and a
   quarter of it, timing one stage (operator + linear combination + limiter), one step at a
   fixed stage count (so the per-step work -- stability numbers, wet extent, guard checks --
   follows as the difference), the diagnostics row written after every step, and a short run
   with output (snapshots and checkpoints per output time). Costs are linear in the active
   cells between the two calibration points. The kernel compilation of a fresh run is measured
   too (it is part of a run's wall time).

The estimate prints in a few seconds plus the compilation. Each timing is repeated: the median
predicts a run started now, at the machine's present load (``wall_s``); the minimum what the
same run takes with no other job in the way (``wall_idle_s``). On a shared machine the two can
differ by several times, and a run takes longer when the load grows while it runs.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..model.physics.viscosity import VISCOSITY
from ..solver.timestepping import stepper_for

# Flow-model constants (see the module docstring for where they come from).
HEAD_THICKNESS = 2.5  # coarse-rich head thickness / h0 before fingering
CHANNEL_SPEED = 2.0  # channel speed / u0 once fingers have formed (paper, section 6.2)
CHANNEL_THICKNESS = 2.0  # channel thickness / h0 once fingers have formed
T_ONSET = 5.1  # [s] the front becomes unstable (figure 12)
T_FORMED = 7.5  # [s] fingers formed (figure 12)
FRONT_SPEED = 0.8  # front speed / u0 of a segregating front (measured, 100-250 cells/m)
SLOW_BEFORE = 1.0 / 4.0  # slowest wet speed / u0 before fingering (measured rho_fric)
SLOW_FINGERS = 1.0 / 30.0  # slowest wet speed / u0 with levees (measured rho_fric)
CROSS_SPEED = 0.2  # |v| / u0 in the fingers
SAMPLES = 400  # time samples of the model over the run
CAL_FRACTION = 0.25  # the smaller calibration wet fraction of x


# =================================================================================================
# Flow model
# =================================================================================================
@dataclass
class FlowModel:
    """Functions of time t [s] describing what limits the step (see the module docstring)."""

    kind: str
    ax: object  # t -> largest a along x [m/s]
    ay: object  # t -> largest a along y [m/s]
    h_max: object  # t -> largest thickness [m]
    u_slow: object  # t -> slowest wet speed [m/s] (friction stiffness)
    wet: object  # t -> (x_lo, x_hi) wet range [m], or None (everything)
    notes: list = field(default_factory=list)


def _ramp(t: float, t0: float, t1: float) -> float:
    """0 before t0, 1 after t1, linear between."""
    if t <= t0:
        return 0.0
    if t >= t1:
        return 1.0
    return (t - t0) / (t1 - t0)


def flow_model(scene) -> FlowModel:
    """The flow model of a scene from its steady state and set-up."""
    m, fl = scene.material, scene.flow
    gc = m.g * math.cos(m.zeta)

    def seg(u, phi):
        # segregation wave speed |u (1 - G'(phi))| (5.26) of the scene's transport function;
        # none without a phi field
        return abs(u * (1.0 - float(m.dG(phi)))) if scene.segregation else 0.0

    def speed(u, h, phi):
        return max(abs(u) + math.sqrt(gc * max(h, 0.0)), seg(u, phi))

    if scene.has_inflow:
        inf = scene.inflow
        h_in, u_in, phi_in = inf.h, inf.u, inf.phi
        a_in = speed(u_in, h_in, phi_in)
        c_in = math.sqrt(gc * h_in)
        fingers = scene.feedback and phi_in < 1.0  # a coarse-rich head can form
        two_d = not scene.is_1d
        front = FRONT_SPEED if fingers else 1.0
        a_head = speed(u_in, HEAD_THICKNESS * fl.h0, phi_in) if fingers else a_in
        a_ch = (
            speed(CHANNEL_SPEED * u_in, CHANNEL_THICKNESS * fl.h0, phi_in)
            if fingers and two_d
            else a_head
        )
        h_top = HEAD_THICKNESS * fl.h0 if fingers else h_in

        def ax(t):
            r1, r2 = _ramp(t, 0.0, T_ONSET), _ramp(t, T_ONSET, T_FORMED)
            return a_in + (a_head - a_in) * r1 + (a_ch - a_head) * r2

        def ay(t):
            if not two_d:
                return 0.0
            h = h_in + (h_top - h_in) * _ramp(t, 0.0, T_ONSET)
            v = CROSS_SPEED * u_in * _ramp(t, T_ONSET, T_FORMED) if fingers else 0.0
            return v + math.sqrt(gc * h)

        def h_max(t):
            return h_in + (h_top - h_in) * _ramp(t, 0.0, T_ONSET)

        def u_slow(t):
            # interpolate the friction stiffness (1 / u_slow), not u_slow itself
            r = _ramp(t, T_ONSET, T_FORMED) if fingers and two_d else 0.0
            inv = (1.0 - r) / (SLOW_BEFORE * u_in) + r / (SLOW_FINGERS * u_in)
            return 1.0 / inv

        def wet(t):
            return (0.0, min(scene.domain.Lx, front * u_in * t))

        notes = [f"inflow a = {a_in:.3f} m/s (u0 + sqrt(g' h0) = {u_in + c_in:.3f})"]
        if fingers:
            notes.append(
                f"coarse head {HEAD_THICKNESS:g} h0 by t = {T_ONSET:g} s: a = {a_head:.3f} m/s"
            )
            if two_d:
                notes.append(
                    f"fingers by t = {T_FORMED:g} s: channels {CHANNEL_SPEED:g} u0 on "
                    f"{CHANNEL_THICKNESS:g} h0, a = {a_ch:.3f} m/s, levees at "
                    f"u0/{1 / SLOW_FINGERS:.0f}"
                )
        notes.append(f"front at {front:g} u0 = {front * u_in:.3f} m/s")
        return FlowModel("inflow", ax, ay, h_max, u_slow, wet, notes)

    ini = scene.initial
    if ini.kind == "uniform":
        u0 = fl.u0 or 0.0
        amp = abs(ini.amplitude or 0.0)
        h = fl.h0 * (1.0 + amp)
        a = speed(u0, h, fl.phi0)
        return FlowModel(
            "uniform",
            lambda t: a,
            lambda t: 0.0 if scene.is_1d else math.sqrt(gc * h) + amp * u0,
            lambda t: h,
            lambda t: max(u0 * (1.0 - amp), 1e-12),
            lambda t: None,
            [f"uniform flow a = {a:.3f} m/s throughout"],
        )

    if ini.kind in ("dam-break", "release"):
        if ini.kind == "dam-break":
            h = max(ini.h_left or 0.0, ini.h_right or 0.0)
            x0, x1 = (
                (0.0, ini.x0)
                if (ini.h_left or 0.0) >= (ini.h_right or 0.0)
                else (ini.x0, scene.domain.Lx)
            )
            if min(ini.h_left or 0.0, ini.h_right or 0.0) >= scene.numerics.h_min:
                x0, x1 = 0.0, scene.domain.Lx  # wet on both sides: everything
        else:
            h = ini.h
            x0, x1 = ini.x0, ini.x1
        c = math.sqrt(gc * h)
        # front speed: 2 c at the tip of a dry-bed rarefaction, less where h < h_min is cut off
        tip = max(c, 2.0 * c - 2.0 * math.sqrt(gc * scene.numerics.h_min))
        # the least friction the law can give
        from ..run.simulation import largest_acceleration  # (the step limit's, too)

        acc = largest_acceleration(scene)

        def ax(t):
            return tip + acc * t

        def wet(t):
            grow = (tip + 0.5 * acc * t) * t
            return (max(0.0, x0 - c * t), min(scene.domain.Lx, x1 + grow))

        return FlowModel(
            ini.kind,
            ax,
            (lambda t: 0.0) if scene.is_1d else (lambda t: tip),
            lambda t: h,
            lambda t: max(c, 1e-12),
            wet,
            [f"front speed {tip:.3f} m/s + {acc:.3g} m/s^2 t"],
        )

    # an empty chute without inflow: nothing moves
    zero = lambda t: 0.0
    return FlowModel(
        "empty",
        zero,
        zero,
        zero,
        lambda t: math.inf,
        lambda t: (0.0, 0.0),
        ["nothing flows: one step per output interval"],
    )


def spectral_radii(scene, model: FlowModel, t: float) -> tuple[float, float, float, float]:
    """(a_x, a_y, rho_visc, rho_fric) of the model at time t, by the run's own formulas."""
    m = scene.material
    gc = m.g * math.cos(m.zeta)
    ax, ay = model.ax(t), model.ay(t)
    if scene.has_inflow:  # the run never plans with less than the inflow's speed
        ax = max(ax, model.ax(0.0))
    rho_v = 0.0
    if (
        scene.viscous
    ):  # the run's Gershgorin bound for uniform h_max (tiseg.model.physics.viscosity)
        rho_v = VISCOSITY.stiffness_uniform(
            scene.flow.nu, model.h_max(t), scene.dx, scene.dy, scene.is_1d
        )
    rho_f = 0.0
    # a projected friction is no part of the explicit stages (Physics.project_friction)
    fric_source = scene.numerics.friction_scheme == "regularised"
    if scene.effects.friction != "none" and model.kind != "empty" and fric_source:
        u = max(model.u_slow(t), scene.numerics.u_eps)
        rho_f = gc * math.tan(m.zeta) / u
    return ax, ay, rho_v, rho_f


def predict_steps(scene, model: FlowModel | None = None, t_end: float | None = None) -> dict:
    """Steps, operator evaluations and the per-step (t, dt, stages, active cells) of a run."""
    from ..run.simulation import ACTIVE_MARGIN, gravity_step, step_limits

    model = model or flow_model(scene)
    num = scene.numerics
    dt_gravity = gravity_step(scene)
    # (with viscosity a split step adds its viscous stages, counted as the run counts them)
    stepper = stepper_for(num, is_1d=scene.is_1d, viscous=bool(scene.viscous))
    t_end = scene.t_end if t_end is None else t_end
    times = [t for t in scene.output_times if 1e-12 < t <= t_end + 1e-12]
    if not times or times[-1] < t_end - 1e-12:
        times.append(t_end)
    dx = scene.dx
    nx, ny = scene.domain.nx, scene.domain.ny
    periodic = scene.boundary.x_lo == "periodic"
    inflow = scene.has_inflow
    h_dt = t_end / SAMPLES
    steps, evals, t0 = 0, 0, 0.0
    rows = []  # (t, dt, stages, active cells, steps in the piece)
    for t1 in (t_end,):
        # sample the run in pieces of about t_end / SAMPLES; the step count is the ceiling of
        # the summed fractions (the last step is trimmed to land on t_end)
        n_piece = max(1, int(math.ceil((t1 - t0) / h_dt)))
        edges = np.linspace(t0, t1, n_piece + 1)
        frac_total, pieces = 0.0, []
        for a, b in zip(edges[:-1], edges[1:]):
            tm = 0.5 * (a + b)
            ax, ay, rv, rf = spectral_radii(scene, model, tm)
            dt_cfl, rho = step_limits(ax, ay, max(rv, rf), scene, None, dt_gravity)
            if not math.isfinite(dt_cfl) and rho == 0:
                dt_cfl = b - a
            if stepper.split:  # the viscous sub-step's stages follow the viscous stiffness
                rho = rv  # alone (Simulation.plan)
            dt, s = stepper.plan(dt_cfl, rho, t1 - t0)
            n = (b - a) / dt
            frac_total += n
            pieces.append((tm, dt, s, n))
        n_int = max(1, int(math.ceil(frac_total - 1e-9)))
        scale = n_int / frac_total if frac_total > 0 else 0.0
        for tm, dt, s, n in pieces:
            n *= scale
            if periodic:
                active = nx
            else:
                lo, hi = model.wet(tm) or (0.0, scene.domain.Lx)
                pad = s + ACTIVE_MARGIN
                first = 0 if inflow else max(0, int(lo / dx) - pad)
                last = min(nx, int(math.ceil(hi / dx)) + 1 + pad)
                active = max(0, last - first)
            rows.append((tm, dt, s, active * ny, n))
            evals += s * n
        steps += n_int
        t0 = t1
    return {
        "steps": steps,
        "rhs_evals": int(round(evals)),
        "outputs": len(times) + 1,
        "profile": rows,
    }


# =================================================================================================
# Calibration
# =================================================================================================
@dataclass
class Calibration:
    """Measured costs on the scene's grid in this process [s]."""

    cells: int
    active_cells: tuple  # active cells at the calibration points
    stage_s: tuple  # one stage (operator + combination + limiter) at each point
    step_overhead_s: tuple  # per step beyond its stages at each point
    stage_idle_s: tuple  # the same, minima over the repeats (an idle machine)
    step_overhead_idle_s: tuple
    diagnostics_s: float  # one diagnostics row (totals) per step of a run with output
    output_s: float  # one snapshot + checkpoint at an output time
    compile_s: float  # kernel compilation of a fresh run (first calls)
    setup_s: float  # building the Simulation (before the run starts)
    wall_s: float  # the calibration itself
    arch: str = "cpu"
    precision: str = "f64"
    threads: int = 0

    def stage(self, active: float, idle: bool = False) -> float:
        return _interp(active, self.active_cells, self.stage_idle_s if idle else self.stage_s)

    def overhead(self, active: float, idle: bool = False) -> float:
        return _interp(
            active, self.active_cells, self.step_overhead_idle_s if idle else self.step_overhead_s
        )


def _interp(x, xs, ys):
    """Linear in x through the calibration points (extrapolated; never below 0)."""
    if len(xs) == 1 or xs[0] == xs[-1]:
        return ys[-1]
    slope = (ys[-1] - ys[0]) / (xs[-1] - xs[0])
    return max(0.0, ys[0] + slope * (x - xs[0]))


def _wet_state(sim, fraction: float, rng) -> np.ndarray:
    """Uniform flow (h0, u0 or a wave speed, phi0 with noise) on x < fraction * Lx, dry beyond."""
    sc, lay = sim.scene, sim.layout
    m = sc.material
    h0 = sc.flow.h0
    u0 = sc.flow.u0 or math.sqrt(m.g * max(math.cos(m.zeta), 1e-3) * h0)
    q = np.zeros((lay.nc, lay.NX, lay.NY))
    ix, iy = lay.interior()
    n_wet = max(1, int(round(fraction * lay.nx)))
    shape = (n_wet, lay.ny)
    h = h0 * (1.0 + 0.05 * rng.random(shape))
    sl = (slice(lay.gx, lay.gx + n_wet), iy)
    q[lay.H][sl] = h
    q[lay.HU][sl] = h * u0
    if not lay.is_1d:
        q[lay.HV][sl] = h * 0.05 * u0 * (rng.random(shape) - 0.5)
    if lay.segregation:
        phi = np.clip(sc.flow.phi0 + 0.1 * (rng.random(shape) - 0.5), 0.0, 1.0)
        q[lay.HPHI][sl] = h * phi
    return q


def _load(sim, q_full: np.ndarray) -> None:
    """Put a full state (ghosts included) into slot 0 as a fresh start: zero boundary budget
    and the state's own mass as the initial mass, so the run's mass-balance guard agrees."""
    sim.op.set(0, q_full)
    sim.op.reset_budget()
    sim.initial_totals = sim.totals()


def _timed(fn, repeats: int, min_s: float) -> tuple[float, float]:
    """(median, minimum) over ``repeats`` batches (each at least ``min_s``) of the mean time
    of one call of fn, after one warm-up call. The median is what a call costs at the
    machine's present load (what a run started now will see); the minimum what it costs with
    no other job in the way."""
    t0 = time.perf_counter()
    fn()
    one = max(time.perf_counter() - t0, 1e-7)
    inner = max(1, min(200, int(min_s / one)))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        times.append((time.perf_counter() - t0) / inner)
    return float(np.median(times)), min(times)


def calibrate(
    scene,
    arch: str | None = None,
    precision: str | None = None,
    threads: int = 0,
    output: bool = True,
    repeats: int = 5,
    sim=None,
) -> Calibration:
    """Time the scene's own kernels on its grid in this process (see the module docstring).
    ``sim``: a fresh Simulation of ``scene`` to time instead of building one (the viewer
    calibrates the one it then shows, after a reset, so that its kernels compile once)."""
    from ..log import info
    from ..run.simulation import Simulation

    # what the estimate costs, said before it is paid (tens of seconds on the finest grids)
    grid = f"{scene.domain.nx} x {scene.domain.ny}"
    info(f"estimate: compiling and timing the scene's kernels on its {grid} grid")
    w0 = time.perf_counter()
    if sim is None:
        sim = Simulation(scene, arch=arch, precision=precision, threads=threads)
    setup = time.perf_counter() - w0
    op, lay = sim.op, sim.layout
    rng = np.random.default_rng(0)
    stepper = sim.stepper
    rkc = stepper.stage_cap and not stepper.split  # stages of L as many as the stiffness asks
    n_terms = 5 if rkc else 3
    terms = [(1.0, 0)] + [(0.0, 0)] * (n_terms - 1)
    spare = op.nslots - 1

    if stepper.split:

        def stage():  # a stage is a sweep (it moves slot 0 by a negligible step)
            op.sweep(0, sim.t, 1e-12)

    else:

        def stage():
            op.rhs(0, 1, sim.t)
            op.combine(spare, terms, limit=True)

    # the step at a fixed stage count: its time less that many stages is the per-step work
    s_cal = 2 if rkc else (stepper.sweeps if stepper.split else stepper.stages)
    far = sim.t + 1e9  # a target never reached: no trimmed steps

    fixed = s_cal if rkc else None

    def steps(k):
        for _ in range(k):
            sim.step(far, stages=fixed)

    fractions = (
        (1.0,) if (scene.boundary.x_lo == "periodic" or lay.nx < 40) else (CAL_FRACTION, 1.0)
    )
    actives = []
    med = {"stage": [], "over": []}
    low = {"stage": [], "over": []}
    compile_s = 0.0
    check = getattr(sim, "check_every", 0) or 1
    # A short run with output on the fresh simulation compiles every kernel a run uses
    # (steps, snapshot, checkpoint); the same run again costs only its work: the difference
    # is the compilation at the start of a real run, the second run's time less its steps the
    # cost of its two output times.
    q_full = _wet_state(sim, 1.0, rng)
    first = _short_run(sim, q_full) if output else None
    second = _short_run(sim, q_full) if output else None
    for k, f in enumerate(fractions):
        q_full = _wet_state(sim, f, rng)
        _load(sim, q_full)
        if k == 0 and not output:  # first calls compile: the compile time of a run
            c0 = time.perf_counter()
            steps(1)
            compile_s = time.perf_counter() - c0
            _load(sim, q_full)
        sim.plan(far)  # sets the active range of this state
        actives.append((op.active[1] - op.active[0]) * lay.ny)
        st_med, st_min = _timed(stage, repeats, 0.05)
        # whole steps, as many as the guard's period so that its check is counted once
        t0 = time.perf_counter()
        steps(1)
        one = time.perf_counter() - t0
        n = check if one * check < 2.0 else 1
        walls = []
        for _ in range(repeats if one * n < 1.0 else 1):
            _load(sim, q_full)
            t0 = time.perf_counter()
            steps(n)
            walls.append((time.perf_counter() - t0) / n)
        _load(sim, q_full)
        med["stage"].append(st_med)
        low["stage"].append(st_min)
        med["over"].append(max(0.0, float(np.median(walls)) - s_cal * st_med))
        low["over"].append(max(0.0, min(walls) - s_cal * st_min))
        if k == 0 and not output:
            compile_s = max(0.0, compile_s - float(np.median(walls)))
    diag, _ = _timed(lambda: sim.totals(), repeats, 0.02)
    out_s = 0.0
    if output:
        (t1, _), (t2, (n2, s2)) = first, second
        compile_s = max(0.0, t1 - t2)
        step2 = n2 * (s2 / max(n2, 1) * med["stage"][-1] + med["over"][-1])
        out_s = max(0.0, (t2 - step2) / 2.0)
    return Calibration(
        cells=lay.nx * lay.ny,
        active_cells=tuple(actives),
        stage_s=tuple(med["stage"]),
        step_overhead_s=tuple(med["over"]),
        stage_idle_s=tuple(low["stage"]),
        step_overhead_idle_s=tuple(low["over"]),
        diagnostics_s=diag,
        output_s=out_s,
        compile_s=compile_s,
        setup_s=setup,
        wall_s=time.perf_counter() - w0,
        arch=sim.backend.arch,
        precision=sim.backend.precision,
        threads=sim.backend.threads,
    )


def _short_run(sim, q_full) -> tuple[float, tuple[int, int]]:
    """Wall time and (steps, stages) of ``Simulation.run`` with output from t = 0 (state
    ``q_full``) to one step later: two snapshots (start, end), their diagnostics rows and a
    checkpoint, as at the output times of a real run."""
    with tempfile.TemporaryDirectory(prefix="tiseg-estimate-") as tmp:
        sim.reset()
        _load(sim, q_full)
        t0 = time.perf_counter()  # the planning compiles kernels too: timed
        dt = sim.plan(1e9).dt
        later = [t for t in sim.scene.output_times if t > 0]
        t_end = min(dt, 0.5 * min(later)) if later else dt
        sim.run(out_dir=Path(tmp) / "run", progress=False, t_end=t_end)
        wall = time.perf_counter() - t0
    return wall, (sim.stats.steps, sim.stats.stages)


# =================================================================================================
# The estimate
# =================================================================================================
@dataclass
class Estimate:
    scene: str
    grid: tuple
    t_end: float
    steps: int
    rhs_evals: int
    mean_stages: float
    dt_min: float
    dt_max: float
    mean_active_cells: float
    wall_steps_s: float  # stepping (stages + per-step work)
    wall_diagnostics_s: float  # the diagnostics row per step (runs with output)
    wall_output_s: float  # snapshots and checkpoints at output times
    wall_compile_s: float  # kernel compilation at the start of the run
    wall_s: float  # all of the above: what `tiseg run` reports as wall time
    wall_idle_s: float  # the same with the calibration's minima (an idle machine)
    setup_s: float  # building the simulation before the run (not in wall_s)
    model: list
    calibration: dict

    def as_dict(self) -> dict:
        return asdict(self)

    def lines(self) -> list[str]:
        c = self.calibration
        return [
            f"{self.scene}: {self.grid[0]} x {self.grid[1]} cells to t = {self.t_end:g} s",
            f"  steps {_count(self.steps)}, operator evaluations {_count(self.rhs_evals)} "
            f"(mean {self.mean_stages:.2f} stages per step), dt {self.dt_min:.3g} .. {self.dt_max:.3g} s, "
            f"mean active cells {self.mean_active_cells:.0f} ({100 * self.mean_active_cells / max(1, self.grid[0] * self.grid[1]):.0f} %)",
            f"  wall time about {_hms(self.wall_s)} at the machine's present load "
            f"({_hms(self.wall_idle_s)} idle) on {c['arch']}/{c['precision']} "
            f"({c['threads'] or 'all'} threads): stepping {_hms(self.wall_steps_s)}, diagnostics "
            f"{_hms(self.wall_diagnostics_s)}, output {_hms(self.wall_output_s)}, compilation "
            f"{_hms(self.wall_compile_s)} (+ {_hms(self.setup_s)} set-up)",
            "  model: " + "; ".join(self.model),
            f"  calibration: stage {1e3 * c['stage_s'][-1]:.3g} ms and per-step work "
            f"{1e3 * c['step_overhead_s'][-1]:.3g} ms on {c['active_cells'][-1]} active cells "
            f"(took {c['wall_s']:.1f} s)",
        ]


def _count(n: int) -> str:
    """A count as digits up to a billion, then as 1.23e+15 (not hundreds of digits)."""
    return str(n) if n < 10**9 else f"{float(n):.3g}"


def _hms(s: float) -> str:
    if s < 60:
        return f"{s:.1f} s"
    if s < 3600:
        return f"{s / 60:.1f} min"
    if s < 3600 * 1e6:
        return f"{s / 3600:.2f} h"
    return f"{s / 3600:.3g} h"


def estimate(
    scene,
    arch: str | None = None,
    precision: str | None = None,
    threads: int = 0,
    output: bool = True,
    calibration: Calibration | None = None,
    t_end: float | None = None,
) -> Estimate:
    """Predict a run of ``scene`` (a `tiseg.setup.scene.Scene`) on this machine.

    ``output``: the run writes files (snapshots, checkpoints, a diagnostics row per step), as
    ``tiseg run`` does; False for ``Simulation.advance`` without output."""
    model = flow_model(scene)
    pred = predict_steps(scene, model, t_end)
    cal = calibration or calibrate(scene, arch, precision, threads, output=output)
    wall_steps = idle_steps = diag = 0.0
    evals = 0.0
    dts, act_sum, n_sum = [], 0.0, 0.0
    # a split step's calibrated stage is a sweep; its viscous stages are part of the measured
    # per-step work (calibrate), so only the sweeps are priced as stages
    base = stepper_for(scene.numerics, is_1d=scene.is_1d, viscous=bool(scene.viscous))
    sweeps = base.sweeps if base.split else None
    for _tm, dt, s, active, n in pred["profile"]:
        priced = s if sweeps is None else sweeps
        wall_steps += n * (cal.overhead(active) + priced * cal.stage(active))
        idle_steps += n * (cal.overhead(active, True) + priced * cal.stage(active, True))
        if output:
            diag += n * cal.diagnostics_s
        evals += n * s
        dts.append(dt)
        act_sum += n * active
        n_sum += n
    out = (pred["outputs"] * cal.output_s) if output else 0.0
    total = wall_steps + diag + out + cal.compile_s
    return Estimate(
        scene=scene.name,
        grid=(scene.domain.nx, scene.domain.ny),
        t_end=scene.t_end if t_end is None else t_end,
        steps=pred["steps"],
        rhs_evals=pred["rhs_evals"],
        mean_stages=evals / max(n_sum, 1e-12),
        dt_min=min(dts) if dts else 0.0,
        dt_max=max(dts) if dts else 0.0,
        mean_active_cells=act_sum / max(n_sum, 1e-12),
        wall_steps_s=wall_steps,
        wall_diagnostics_s=diag,
        wall_output_s=out,
        wall_compile_s=cal.compile_s,
        wall_s=total,
        wall_idle_s=total - wall_steps + idle_steps,
        setup_s=cal.setup_s,
        model=model.notes,
        calibration=asdict(cal),
    )
