"""How fast the operator and the steps run, what each effect costs, and how far from the limit.

``tiseg bench throughput [--nx 1125 --ny 375] [--json] [--quick]`` measures, in one run and for
each backend and precision (each in its own child process),

* **cell-updates per second**: one evaluation of the semi-discrete operator for one cell
  (``TaichiOperator.rhs``), over a fully wet, noisy uniform flow so that every cell does all the
  work (the paper's resolution, 750 cells per metre, on the given grid);
* **steps per second** of ``Simulation.step`` (stability numbers, dt and stage count, and the
  stepper's stages: operator, linear combination and limiter each), and from steps at a fixed
  2 and 6 RKC stages the cost of one stage inside a step and of the per-step work (a stage in
  a step is slower than the operator alone: all of RKC's state slots are in use and less of the
  data is in cache);
* the same **with each effect switched off in turn** (segregation, mobility feedback,
  viscosity, friction "none", and 1D instead of 2D with the same number of cells);
* the **NumPy reference** (`tiseg.solver.reference`) on the same state: the speed-up of the kernels;
* a **memory-bandwidth bound**: a STREAM-like triad a = b + s c, in Taichi (all threads) and in
  NumPy, over arrays about the size of the operator's fields, measured in the same process. The
  operator must at least read the state and write its rate of change, 2 nc values per cell, so
  no implementation can beat ``cells * 2 nc * bytes / bandwidth`` per evaluation; the ratio to it
  shows how far the kernels are from the limit. The traffic of the kernels as written (each of
  primitives, slopes, fluxes and divergence passes through memory) is reported beside it.

The cost of each effect (`effect_costs`) follows from the variants: per stage and per
step, predicted from the per-stage and per-step costs and the stage counts, and measured on
whole steps, so that one can check that a scene switching an effect off runs faster by about
what the effect costs.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from . import available_backends, log_stderr, machine_info, machine_line, run_child
from ... import backend
from ...solver.reference import ReferenceOperator
from ... import backend as _backend
from ...errors import InputError

PAPER_GRID = (1125, 375)  # 750 cells per metre on 1.5 m x 0.5 m
QUICK_GRID = (96, 32)
RESOLUTION = 750.0  # cells per metre of the throughput grid (dx = dy)

# (name, scene overrides, what is switched off). The full physics is the fingers scene's.
VARIANTS = (
    ("full", {}, "full physics (fingers scene: weno, viscosity, segregation, feedback, 2D)"),
    ("no-segregation", {"effects.segregation": False}, "segregation off (no phi field)"),
    ("no-feedback", {"effects.mobility_feedback": False}, "mobility feedback off"),
    ("no-viscosity", {"effects.viscosity": False}, "viscosity off"),
    ("friction-none", {"effects.friction": "none"}, "friction none"),
    ("1d", {"domain.ny": 1}, "1D (ny = 1) with the same number of cells"),
)
# Effects and the variant that switches each off
EFFECTS = (
    ("segregation", "no-segregation"),
    ("mobility feedback", "no-feedback"),
    ("viscosity (incl. its RKC stages)", "no-viscosity"),
    ("friction", "friction-none"),
    ("2D (vs 1D)", "1d"),
)


# =================================================================================================
# Scenes and timing helpers
# =================================================================================================
def variant_scene(name: str, nx: int, ny: int):
    """The uniform-flow scene with the fingers physics on an nx x ny grid at 750 cells/m,
    noisy phi (noisy h without segregation, which has no phi field) so that slopes and
    limiters do real work, with one variant's switch."""
    from ...setup.scene import load_scene

    overrides = dict(next(v[1] for v in VARIANTS if v[0] == name))
    if overrides.get("domain.ny") == 1:
        nx, ny = nx * ny, 1  # same number of cells in one row
    base = {
        "domain.nx": nx,
        "domain.ny": ny,
        "domain.Lx": None,
        "initial.k": 2 * math.pi * 0.002 / (nx / RESOLUTION),  # one wavelength = Lx
        "initial.mode": "noise" if overrides.get("effects.segregation", True) else "h-noise",
        "initial.amplitude": 0.01,
        "initial.seed": 1,
        "numerics.reconstruction": "weno",
        "numerics.stepper": "rkc",
        # timed steps must never run into the end time (dt would be trimmed to 0)
        "time.t_end": 1e6,
        "output.interval": 1e6,
    }
    if ny > 1:
        base["domain.Ly"] = ny / RESOLUTION
    if overrides.get("effects.friction") == "none":
        # no friction law to derive the steady velocity from: give the full scene's u0
        base["flow.u0"] = load_scene("uniform-flow").flow.u0
    base.update(overrides)
    return load_scene("uniform-flow", base)


def best_time(fn, repeats: int, target_s: float = 0.1, sync=None) -> float:
    """Minimum over ``repeats`` of the mean time of one call of fn, each repeat a batch of
    calls lasting about ``target_s`` (so that timer resolution and launch jitter average out),
    after one warm-up call. The minimum, because other jobs on a shared machine only ever add
    time."""
    fn()
    if sync:
        sync()
    t0 = time.perf_counter()
    fn()
    if sync:
        sync()
    one = max(time.perf_counter() - t0, 1e-7)
    inner = max(1, min(1000, int(target_s / one)))
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        if sync:
            sync()
        best = min(best, (time.perf_counter() - t0) / inner)
    return best


def min_bytes_per_cell(nc: int, nbytes: int) -> int:
    """The least traffic of one evaluation: read the state, write its rate, nc values each."""
    return 2 * nc * nbytes


def implemented_bytes_per_cell(nc: int, nbytes: int, is_1d: bool, first_order: bool) -> int:
    """Traffic of the kernels as written, each pass through memory counted once per cell:
    primitives (read q, write w), slopes (read w, write sx[, sy]), fluxes (read w and the
    slopes, write fx[, fy]) and divergence (read w and the fluxes, write the rate)."""
    dirs = 1 if is_1d else 2
    passes = 2  # primitives
    if not first_order:
        passes += 2 * dirs  # slopes
    passes += dirs * (3 if not first_order else 2)  # fluxes
    passes += 2 + dirs  # divergence
    return passes * nc * nbytes


# =================================================================================================
# Measurements in one process (one precision, one backend)
# =================================================================================================
def triad_bandwidth(n: int, precision: str, repeats: int, target_s: float = 0.1) -> dict:
    """STREAM-like triad a = b + s c over n elements: Taichi kernel (all threads) and NumPy.

    Bytes counted as STREAM does: 3 n values per Taichi triad. NumPy has no fused triad, so its
    a = s c; a += b moves 5 n values, counted as such."""
    import taichi as ti

    dt = np.float64 if precision == "f64" else np.float32
    nbytes = np.dtype(dt).itemsize
    fp = ti.f64 if precision == "f64" else ti.f32
    a = ti.field(fp, shape=n)
    b = ti.field(fp, shape=n)
    c = ti.field(fp, shape=n)

    @ti.kernel
    def fill():
        for i in range(n):
            b[i] = 1.0
            c[i] = 2.0

    @ti.kernel
    def triad():
        for i in range(n):
            a[i] = b[i] + 3.0 * c[i]  # the scalar as a constant: same traffic, no argument

    fill()
    t_ti = best_time(triad, repeats, target_s, ti.sync)
    an, bn, cn = np.zeros(n, dt), np.ones(n, dt), np.full(n, 2.0, dt)

    def np_triad():
        np.multiply(cn, dt(3.0), out=an)
        np.add(an, bn, out=an)

    t_np = best_time(np_triad, repeats, target_s)
    return {
        "elements": n,
        "bytes_per_value": nbytes,
        "taichi_triad_GBps": 3 * n * nbytes / t_ti / 1e9,
        "numpy_triad_GBps": 5 * n * nbytes / t_np / 1e9,
    }


class _Variant:
    """One variant's simulation and the callables that are timed."""

    def __init__(self, name: str, nx: int, ny: int):
        from ...run.simulation import Simulation

        self.name = name
        self.scene = variant_scene(name, nx, ny)
        # the precision measure() initialised, not the scene's (f64): this bench is per precision
        self.sim = sim = Simulation(self.scene, precision=backend.state().precision)
        self.op = sim.op
        self.cells = self.scene.domain.nx * self.scene.domain.ny
        # the stage count of this state (RKC: from the viscous, friction and KT radii)
        p = sim.plan()
        self.dt, self.stages = p.dt, p.stages
        self.q0 = sim.op.get(0)
        self.q_ref = self.q0.copy()

    def rhs(self):
        self.op.rhs(0, 1, 0.0)

    def plan(self):
        self.sim.plan()

    def step(self):
        """A whole step at the stage count the state asks for."""
        self.sim.step()

    def step_fixed(self, stages: int):
        """A whole RKC step at a fixed stage count: two of these give the cost of one stage
        inside a step (operator, combination, limiter, with all of RKC's state slots in use,
        which is slower than the operator alone in a warm cache) and of the per-step work."""
        self.sim.step(stages=stages)

    def restore(self):
        self.op.set(0, self.q0)


def measure_variants(
    names, nx: int, ny: int, repeats: int, target_s: float, numpy_repeats: int, log=None
) -> list[dict]:
    """Operator, stage, plan and step times of the variants, measured side by side.

    All variants are built first; then each quantity is timed for every variant in turn,
    ``repeats`` rounds, keeping each one's minimum: a burst of load from other jobs hits one
    round of all variants alike instead of one variant's whole measurement."""
    import taichi as ti

    vs = []
    for name in names:
        if log:
            log(f"  building {name} ({nx} x {ny})")
        vs.append(_Variant(name, nx, ny))
    timed = {
        "rhs": lambda v: v.rhs,
        "plan": lambda v: v.plan,
        "step": lambda v: v.step,
        "step2": lambda v: lambda: v.step_fixed(2),
        "step6": lambda v: lambda: v.step_fixed(6),
    }
    best = {(v.name, k): math.inf for v in vs for k in timed}
    for _ in range(repeats):
        for v in vs:
            for key, fn in timed.items():
                t = best_time(fn(v), 1, target_s, ti.sync)
                best[(v.name, key)] = min(best[(v.name, key)], t)
                v.restore()  # whole steps changed the state
    rows = []
    for v in vs:
        ref = ReferenceOperator(v.sim.cfg)
        t_np = best_time(lambda: ref.rhs(v.q_ref.copy(), 0.0), numpy_repeats, 0.0)  # noqa: B023
        lay = v.sim.layout
        nbytes = 8 if v.sim.backend.precision == "f64" else 4
        t_rhs, t_step = best[(v.name, "rhs")], best[(v.name, "step")]
        # per stage and per step inside whole steps, from the steps at 2 and 6 stages (a long
        # lever arm: the difference of two noisy times divided by 4)
        t2, t6 = best[(v.name, "step2")], best[(v.name, "step6")]
        in_stage = max((t6 - t2) / 4.0, 1e-12)
        overhead = max(t2 - 2.0 * in_stage, 0.0)
        rows.append(
            {
                "name": v.name,
                "description": next(x[2] for x in VARIANTS if x[0] == v.name),
                "grid": [v.scene.domain.nx, v.scene.domain.ny],
                "cells": v.cells,
                "nc": lay.nc,
                "stages_per_step": v.stages,
                "dt": v.dt,
                "rhs_s": t_rhs,
                "cell_updates_per_s": v.cells / t_rhs,
                "plan_s": best[(v.name, "plan")],
                "stage_s": in_stage,
                "step_overhead_s": overhead,
                "stage_cell_updates_per_s": v.cells / in_stage,
                "step_s": t_step,
                "steps_per_s": 1.0 / t_step,
                "step_predicted_s": overhead + v.stages * in_stage,
                "step_cell_updates_per_s": v.cells * v.stages / t_step,
                "numpy_rhs_s": t_np,
                "numpy_cell_updates_per_s": v.cells / t_np,
                "speedup_vs_numpy": t_np / t_rhs,
                "min_bytes_per_cell": min_bytes_per_cell(lay.nc, nbytes),
                "implemented_bytes_per_cell": implemented_bytes_per_cell(
                    lay.nc, nbytes, lay.is_1d, v.scene.numerics.reconstruction == "first-order"
                ),
            }
        )
    return rows


def measure(
    nx: int,
    ny: int,
    precision: str,
    backend_name: str = "cpu",
    threads: int = 0,
    quick: bool = False,
    variants=None,
    log=None,
) -> dict:
    """Every variant plus the bandwidth for one (precision, backend) in this process."""

    backend.init(backend_name, precision, threads)
    st = backend.state()
    names = list(variants) if variants else [v[0] for v in VARIANTS]
    if log:
        log(f"[{precision}/{backend_name}] {len(names)} variants on {nx} x {ny}")
    repeats, target = (2, 0.02) if quick else (5, 0.3)
    rows = measure_variants(names, nx, ny, repeats, target, 1 if quick else 2, log)
    full = next((r for r in rows if r["name"] == "full"), rows[0])
    # triad arrays: together about the operator's fields (state slots and intermediates)
    n = max(full["cells"] * full["nc"] * 3, 1 << 16)
    bw = triad_bandwidth(n, precision, repeats, target)
    gbps = max(bw["taichi_triad_GBps"], bw["numpy_triad_GBps"])
    for r in rows:
        r["bound_s"] = r["cells"] * r["min_bytes_per_cell"] / (gbps * 1e9)
        r["bound_cell_updates_per_s"] = r["cells"] / r["bound_s"]
        r["times_the_bound"] = r["rhs_s"] / r["bound_s"]
        r["implemented_traffic_s"] = r["cells"] * r["implemented_bytes_per_cell"] / (gbps * 1e9)
    return {
        "precision": precision,
        "backend": backend_name,
        "arch": st.arch,
        "threads": threads,
        "bandwidth": dict(bw, used_GBps=gbps),
        "variants": rows,
    }


# =================================================================================================
# Cost of each effect
# =================================================================================================
def effect_costs(result: dict) -> list[dict]:
    """What each effect adds to a stage and to a step, for one (precision, backend) result.

    A step costs P + s S: per-step work P (stability numbers, wet extent, first RKC stage's
    combination) and s stages of S each (operator, combination, limiter), both measured inside
    whole steps at 2 and 6 stages. The effect's cost per stage is S_full - S_off; the
    predicted saving per step is (P_full + s_full S_full) - (P_off + s_off S_off), which for
    viscosity splits into cheaper stages (s_off (S_full - S_off) and the P difference) and the
    RKC stages it no longer needs ((s_full - s_off) S_full). The measured saving is
    step_full - step_off on whole steps at their own stage counts: the check that switching
    the effect off saves about what it costs."""
    by = {r["name"]: r for r in result["variants"]}
    full = by.get("full")
    out = []
    if full is None:
        return out
    for label, off_name in EFFECTS:
        off = by.get(off_name)
        if off is None:
            continue
        # per cell, so that 1D with its own cell count compares (here the counts are equal)
        ns = lambda r, k: r[k] / r["cells"] * 1e9
        pred_full = full["step_overhead_s"] + full["stages_per_step"] * full["stage_s"]
        pred_off = off["step_overhead_s"] + off["stages_per_step"] * off["stage_s"]
        saving_eval = off["stages_per_step"] * (full["stage_s"] - off["stage_s"])
        saving_stages = (full["stages_per_step"] - off["stages_per_step"]) * full["stage_s"]
        out.append(
            {
                "effect": label,
                "variant": off_name,
                "rhs_ns_per_cell_full": ns(full, "rhs_s"),
                "rhs_ns_per_cell_off": ns(off, "rhs_s"),
                "rhs_cost_ns_per_cell": ns(full, "rhs_s") - ns(off, "rhs_s"),
                "rhs_cost_fraction": 1.0
                - off["rhs_s"] / full["rhs_s"] * full["cells"] / off["cells"],
                "stage_ns_per_cell_full": ns(full, "stage_s"),
                "stage_ns_per_cell_off": ns(off, "stage_s"),
                "stage_cost_ns_per_cell": ns(full, "stage_s") - ns(off, "stage_s"),
                "stage_cost_fraction": 1.0 - ns(off, "stage_s") / ns(full, "stage_s"),
                "stages_full": full["stages_per_step"],
                "stages_off": off["stages_per_step"],
                "step_saving_from_cheaper_stages_s": saving_eval,
                "step_saving_from_fewer_stages_s": saving_stages,
                "step_saving_predicted_s": pred_full - pred_off,
                "step_saving_measured_s": full["step_s"] - off["step_s"],
                "step_saving_predicted_fraction": (pred_full - pred_off) / full["step_s"],
                "step_saving_measured_fraction": (full["step_s"] - off["step_s"]) / full["step_s"],
            }
        )
    return out


# =================================================================================================
# The benchmark and its tables
# =================================================================================================
def run_benchmark(
    nx=None,
    ny=None,
    quick: bool = False,
    precisions=("f64", "f32"),
    backends=None,
    threads: int = 0,
    out_dir=None,
    variants=None,
    in_process: bool | None = None,
    log=None,
) -> dict:
    """Measure every (precision, backend) and return the report (see the module docstring).

    Children are used unless there is one combination and ``in_process`` is not False."""

    if nx is None or ny is None:
        gx, gy = QUICK_GRID if quick else PAPER_GRID
        nx, ny = nx or gx, ny or gy
    for v in variants or ():
        if v not in [x[0] for x in VARIANTS]:
            raise InputError(f"variant {v!r}: choose from {', '.join(x[0] for x in VARIANTS)}")
    backends = list(backends) if backends else available_backends()
    combos = [(p, b) for b in backends for p in precisions]
    if in_process is None:
        in_process = len(combos) == 1
    if in_process and len(combos) > 1:
        raise InputError("in-process runs take one precision and one backend")
    t0 = time.perf_counter()
    results = []
    work = None if in_process else (Path(out_dir) / ".work" if out_dir else _tmp_work())
    for prec, be in combos:
        if in_process:
            thr = threads or (_backend.state().threads if _backend.is_initialised() else 0)
            results.append(measure(nx, ny, prec, be, thr, quick, variants, log))
        else:
            results.append(
                run_child(
                    "tiseg.apps.bench.throughput",
                    {
                        "nx": nx,
                        "ny": ny,
                        "precision": prec,
                        "backend": be,
                        "threads": threads,
                        "quick": quick,
                        "variants": list(variants) if variants else None,
                    },
                    work,
                    f"{prec}-{be}",
                )
            )
    for r in results:
        r["effects"] = effect_costs(r)
    report = {
        "machine": machine_info(threads),
        "grid": {"nx": nx, "ny": ny, "cells": nx * ny, "cells_per_metre": RESOLUTION},
        "quick": quick,
        "wall_s": time.perf_counter() - t0,
        "results": results,
    }
    if out_dir is not None:
        from ...output import write_json_atomic, write_text_atomic

        out = Path(out_dir)
        write_json_atomic(out / "throughput.json", report)
        write_text_atomic(out / "throughput.md", markdown(report))
        write_json_atomic(
            out / "effects.json",
            {
                "machine": report["machine"],
                "grid": report["grid"],
                "effects": {f"{r['precision']}/{r['backend']}": r["effects"] for r in results},
            },
        )
        write_text_atomic(out / "effects.md", effects_markdown(report))
    return report


def _tmp_work() -> Path:
    import tempfile

    return Path(tempfile.mkdtemp(prefix="tiseg-bench-"))


def throughput_markdown(report: dict) -> str:
    g = report["grid"]
    lines = [
        f"Operator throughput on {g['nx']} x {g['ny']} cells ({machine_line(report['machine'])})",
        "",
        "| variant | prec/backend | operator M cell-updates/s | NumPy M/s | x NumPy "
        "| bound M/s | x bound | stage in a step M/s | steps/s | stages/step "
        "| step: measured / P + s S |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for res in report["results"]:
        for v in res["variants"]:
            lines.append(
                f"| {v['name']} | {res['precision']}/{res['backend']} | "
                f"{v['cell_updates_per_s'] / 1e6:.2f} | {v['numpy_cell_updates_per_s'] / 1e6:.3f} | "
                f"{v['speedup_vs_numpy']:.1f} | {v['bound_cell_updates_per_s'] / 1e6:.0f} | "
                f"{v['times_the_bound']:.0f} | {v['stage_cell_updates_per_s'] / 1e6:.2f} | "
                f"{v['steps_per_s']:.2f} | {v['stages_per_step']} | "
                f"{1e3 * v['step_s']:.0f} / {1e3 * v['step_predicted_s']:.0f} ms |"
            )
    lines.append("")
    for res in report["results"]:
        bw = res["bandwidth"]
        full = next((v for v in res["variants"] if v["name"] == "full"), res["variants"][0])
        lines.append(
            f"- {res['precision']}/{res['backend']}: triad {bw['taichi_triad_GBps']:.1f} GB/s "
            f"(Taichi), {bw['numpy_triad_GBps']:.1f} GB/s (NumPy) over {bw['elements']} values; "
            f"bound = {full['min_bytes_per_cell']} B/cell (read q, write dq/dt) / "
            f"{bw['used_GBps']:.1f} GB/s; the kernels as written move about "
            f"{full['implemented_bytes_per_cell']} B/cell, i.e. "
            f"{full['implemented_traffic_s'] * 1e3:.2f} ms per evaluation at that bandwidth "
            f"against {full['rhs_s'] * 1e3:.2f} ms measured."
        )
    return "\n".join(lines)


def effects_markdown(report: dict) -> str:
    lines = [
        f"Cost of each effect on {report['grid']['nx']} x {report['grid']['ny']} cells "
        f"({machine_line(report['machine'])})",
        "",
        "| effect | prec/backend | operator ns/cell (full → off) | stage in a step ns/cell "
        "(full → off) | cost per stage | RKC stages (full → off) | step saving predicted "
        "| step saving measured |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for res in report["results"]:
        for e in res["effects"]:
            lines.append(
                f"| {e['effect']} | {res['precision']}/{res['backend']} | "
                f"{e['rhs_ns_per_cell_full']:.0f} → {e['rhs_ns_per_cell_off']:.0f} | "
                f"{e['stage_ns_per_cell_full']:.0f} → {e['stage_ns_per_cell_off']:.0f} | "
                f"{100 * e['stage_cost_fraction']:.0f} % | {e['stages_full']} → {e['stages_off']} | "
                f"{100 * e['step_saving_predicted_fraction']:.0f} % | "
                f"{100 * e['step_saving_measured_fraction']:.0f} % |"
            )
    return "\n".join(lines)


def markdown(report: dict) -> str:
    return throughput_markdown(report) + "\n\n" + effects_markdown(report) + "\n"


# =================================================================================================
# Child process entry
# =================================================================================================
def _child(task_path: str) -> int:
    task = json.loads(Path(task_path).read_text())

    res = measure(
        task["nx"],
        task["ny"],
        task["precision"],
        task["backend"],
        task.get("threads", 0),
        task.get("quick", False),
        task.get("variants"),
        log_stderr,
    )
    Path(task["result"]).write_text(json.dumps(res))
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tiseg.apps.bench.throughput")
    ap.add_argument("--child", required=True, help=argparse.SUPPRESS)
    return _child(ap.parse_args(argv).child)


if __name__ == "__main__":  # pragma: no cover - entered in the child processes
    sys.exit(main())
