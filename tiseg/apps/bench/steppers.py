"""Which time stepper for this run? Time-stepping error and cost from a run's own saved states.

``tiseg bench steppers RUN_DIR`` restarts from snapshots of a finished (or running) run, on its
own grid, physics and precision, and advances each stepper (by default rkc, ssprk3, ssprk2,
ssprk4_2, ssprk10_4 and euler; any registered one with ``--steppers``) over the same short span
at the run's Courant number. The reference is SSP-RK3 at a five times smaller
Courant number. Every run shares the grid and the spatial discretisation, so the differences
are the time-stepping errors alone, measured where they matter: at the run's resolution, in its
own late, stiff states (thin levees, slow margins), which no small reference problem reproduces.

Error: the relative L1 difference to the reference of h and of h phi after the span (the larger
of the two is what the Pareto front uses). Wall time: the minimum over ``repeats`` timed
advances after a warm-up step (kernels compiled). Output: ``steppers.json`` and ``steppers.md``
(one table per start time, the Pareto front marked, and whether the run's own stepper is on it).

Why this and not only ``tiseg bench accuracy``: on small grids the steps are set by the CFL limit
and a one-stage stepper looks cheapest; on the paper's grid (750 cells/m) the viscous and friction
stiffness shortens the single-stage steppers' steps, and only a measurement at that grid can say
what a stepper costs there (benchmarks/README.md, section 3).
"""

from __future__ import annotations

from ...output.names import FIELDS_FILE, SCENE_FILE

import math
import time
from pathlib import Path
from typing import Sequence

import numpy as np

from ...errors import InputError
from ... import backend
from ...solver.timestepping import STEPPERS as KNOWN
from . import machine_info
from . import machine_line

STEPPERS = ("rkc", "ssprk3", "ssprk2", "ssprk4_2", "ssprk10_4", "euler")
REFERENCE_STEPPER = "ssprk3"
REFERENCE_CFL_FACTOR = 0.2


def _run_scene(run_dir: Path):
    from ...setup.scene import load_scene

    path = run_dir / SCENE_FILE
    if not path.is_file():
        raise InputError(f"{run_dir}: no scene.toml here; give the folder of a tiseg run")
    return load_scene(path)


def _states(run_dir: Path, times: Sequence[float] | None, count: int = 2):
    """[(t, conserved (nc, nx, ny))] from the run's fields.nc at the snapshots nearest
    ``times`` (default: ``count`` snapshots, the last and ones evenly before it, t > 0)."""
    from ...output.netcdf import read_fields

    path = run_dir / FIELDS_FILE
    if not path.is_file():
        raise InputError(f"{run_dir}: no fields.nc here (the run saved no snapshots)")
    ds = read_fields(path)
    try:
        tt = np.asarray(ds["time"].values, dtype=float)
        if tt.size == 0 or tt.max() <= 0:
            raise InputError(f"{path}: no snapshot after t = 0 to start from")
        if times:
            idx = []
            for t in times:
                k = int(np.argmin(np.abs(tt - t)))
                if abs(tt[k] - t) > 1e-6 * max(1.0, abs(t)):
                    raise InputError(
                        f"--times {t:g}: the run has no snapshot at that time "
                        f"(saved: {', '.join(f'{v:g}' for v in tt[:12])}"
                        f"{' ...' if tt.size > 12 else ''})"
                    )
                idx.append(k)
        else:
            pos = np.nonzero(tt > 0)[0]
            idx = sorted(
                {int(pos[round(f * (len(pos) - 1))]) for f in np.linspace(1.0 / count, 1.0, count)}
            )
        out = []
        for k in idx:
            f = {
                c: np.asarray(ds[c].isel(time=k).values, dtype=float).T
                for c in ("h", "u", "v", "phi")
                if c in ds
            }
            h = np.nan_to_num(f["h"])
            comps = [h, h * np.nan_to_num(f["u"])]
            if "v" in f:
                comps.append(h * np.nan_to_num(f["v"]))
            if "phi" in f:
                comps.append(h * np.nan_to_num(f["phi"]))
            out.append((float(tt[k]), np.stack(comps)))
        return out
    finally:
        ds.close()


def _advance(sim, q0, t0: float, span: float, repeats: int):
    """Minimum wall time of advancing q0 from t0 by span; the final state and the counts."""
    import taichi as ti

    best = math.inf
    for _ in range(max(1, repeats)):
        sim.set_conserved(q0)
        sim.t = t0
        sim.step(t0 + span)  # warm-up (compiles this stepper's kernels)
        sim.set_conserved(q0)
        sim.t = t0
        steps0, evals0 = sim.stats.steps, sim.stats.stages
        w0 = time.perf_counter()
        sim.advance(t0 + span)
        ti.sync()
        best = min(best, time.perf_counter() - w0)
    return best, sim.conserved(), sim.stats.steps - steps0, sim.stats.stages - evals0


def _rel_l1(a: np.ndarray, b: np.ndarray) -> float:
    den = float(np.abs(b).sum())
    return float(np.abs(a - b).sum() / den) if den > 0 else float(np.abs(a - b).sum())


def measure(
    run_dir,
    times: Sequence[float] | None = None,
    span: float | None = None,
    steppers: Sequence[str] = STEPPERS,
    repeats: int = 2,
    arch: str = "cpu",
    threads: int = 0,
    log=None,
) -> dict:
    """Measure every stepper from the run's snapshots; return the report (see module doc)."""
    from ...run.simulation import Simulation
    from .accuracy import pareto_front

    run_dir = Path(run_dir)
    for s in steppers:
        if s not in KNOWN:
            raise InputError(f"stepper {s!r} is not known; choose from {', '.join(sorted(KNOWN))}")
    if span is not None and not (span > 0 and math.isfinite(span)):
        raise InputError(f"--span {span!r}: must be a positive number of seconds")
    if repeats < 1:
        raise InputError(f"--repeats {repeats}: must be >= 1")
    scene = _run_scene(run_dir)
    if scene.numerics.stepper not in steppers:  # the verdict is about the run's own stepper
        steppers = (*steppers, scene.numerics.stepper)
    states = _states(run_dir, times)
    shape = (scene.domain.nx, scene.domain.ny)
    if states and states[0][1].shape[1:] != shape:
        raise InputError(
            f"{run_dir}: scene.toml describes {shape[0]} x {shape[1]} cells but "
            f"fields.nc holds {states[0][1].shape[1]} x {states[0][1].shape[2]}: "
            "scene.toml was edited after the run; restore it"
        )
    cfl = scene.numerics.cfl
    prec = scene.numerics.precision
    backend.init(arch, prec, threads)
    base = {"time.t_end": 1e9, "output.times": [], "output.interval": 1e9}
    report = {
        "run": str(run_dir),
        "scene": scene.name,
        "cells": [scene.domain.nx, scene.domain.ny],
        "precision": prec,
        "arch": backend.state().arch,
        "cfl": cfl,
        "own_stepper": scene.numerics.stepper,
        "reference": {"stepper": REFERENCE_STEPPER, "cfl": cfl * REFERENCE_CFL_FACTOR},
        "machine": machine_info(threads),
        "starts": [],
    }
    sims = {}

    def sim_for(stepper: str, c: float):
        key = (stepper, c)
        if key not in sims:
            sc = scene.with_overrides({**base, "numerics.stepper": stepper, "numerics.cfl": c})
            # guards off: the mass balance baseline is the run's start, not this snapshot;
            # finiteness is checked on the result instead
            sims[key] = Simulation(sc, arch=arch, precision=prec, threads=threads, check_every=0)
        return sims[key]

    for t0, q0 in states:
        own = sim_for(scene.numerics.stepper, cfl)
        own.set_conserved(q0)
        own.t = t0
        dt0 = own.plan().dt
        sp = span if span is not None else 40 * dt0  # about 40 steps of the run's own stepper
        if log:
            log(
                f"t = {t0:g} s: span {sp:.3g} s; reference {REFERENCE_STEPPER} at cfl "
                f"{cfl * REFERENCE_CFL_FACTOR:g}"
            )
        ref_wall, ref_q, ref_steps, ref_evals = _advance(
            sim_for(REFERENCE_STEPPER, cfl * REFERENCE_CFL_FACTOR), q0, t0, sp, 1
        )
        if not np.all(np.isfinite(ref_q)):
            raise InputError(f"the reference run from t = {t0:g} s did not stay finite")
        rows = []
        for s in steppers:
            wall, q, steps, evals = _advance(sim_for(s, cfl), q0, t0, sp, repeats)
            ok = bool(np.all(np.isfinite(q)))
            e_h = _rel_l1(q[0], ref_q[0]) if ok else math.nan
            e_p = _rel_l1(q[-1], ref_q[-1]) if ok and scene.effects.segregation else math.nan
            err = max(e_h, e_p) if math.isfinite(e_p) else e_h
            rows.append(
                {
                    "stepper": s,
                    "wall_s": wall,
                    "steps": steps,
                    "evaluations": evals,
                    "error_h": e_h,
                    "error_hphi": e_p,
                    "error": err,
                    "status": "ok" if ok else "unstable",
                }
            )
            if log:
                log(
                    f"  {s}: {wall:.3g} s, {steps} steps, {evals} evaluations, "
                    f"L1(h) {e_h:.3g}, L1(h phi) {e_p:.3g}"
                )
        front = pareto_front([r["error"] for r in rows], [r["wall_s"] for r in rows])
        for i, r in enumerate(rows):
            r["pareto"] = i in front
        report["starts"].append(
            {
                "time": t0,
                "span": sp,
                "reference_wall_s": ref_wall,
                "reference_steps": ref_steps,
                "reference_evaluations": ref_evals,
                "rows": rows,
            }
        )
    report["verdict"] = verdict(report)
    return report


def verdict(report: dict) -> str:
    """Is the run's own stepper on the Pareto front at every start time?"""
    own = report["own_stepper"]
    lines = []
    for st in report["starts"]:
        rows = {r["stepper"]: r for r in st["rows"]}
        if own not in rows:
            continue
        r = rows[own]
        front = [x for x in st["rows"] if x["pareto"]]
        cheaper = [x for x in front if x["wall_s"] < r["wall_s"] and x["stepper"] != own]
        if r["pareto"]:
            note = "on the Pareto front"
            if cheaper:
                c = min(cheaper, key=lambda x: x["wall_s"])
                note += (
                    f"; {c['stepper']} is {r['wall_s'] / c['wall_s']:.2f}x faster with "
                    f"{c['error'] / r['error']:.3g}x the error"
                    if r["error"] > 0
                    else ""
                )
        else:
            better = [x for x in front if x["error"] <= r["error"]]
            c = min(better, key=lambda x: x["wall_s"]) if better else None
            note = "NOT on the Pareto front" + (
                f": {c['stepper']} is {r['wall_s'] / c['wall_s']:.2f}x faster at no larger error"
                if c
                else ""
            )
        lines.append(f"- t = {st['time']:g} s: {own} {note}")
    return "\n".join(lines)


def markdown(report: dict) -> str:

    out = [
        f"# Time steppers from the states of run `{Path(report['run']).name}` "
        f"({report['scene']}, {report['cells'][0]} x {report['cells'][1]} cells, "
        f"{report['precision']}, {report['arch']})",
        "",
        f"Machine: {machine_line(report['machine'])}. Each stepper at cfl {report['cfl']:g} "
        f"against {report['reference']['stepper']} at cfl {report['reference']['cfl']:g}; "
        "error = relative L1 of h and h phi after the span (the larger decides the front); "
        "wall = minimum over repeats.",
        "",
    ]
    for st in report["starts"]:
        out += [
            f"## From t = {st['time']:g} s over {st['span']:.3g} s "
            f"(reference: {st['reference_steps']} steps, {st['reference_wall_s']:.3g} s)",
            "",
            "| stepper | wall s | steps | evaluations | L1(h) | L1(h phi) | Pareto |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in st["rows"]:
            out.append(
                f"| {r['stepper']}{' (run)' if r['stepper'] == report['own_stepper'] else ''} "
                f"| {r['wall_s']:.3g} | {r['steps']} | {r['evaluations']} | "
                f"{r['error_h']:.3g} | {r['error_hphi']:.3g} | {'yes' if r['pareto'] else ''} |"
            )
        out.append("")
    out += ["Verdict:", report["verdict"], ""]
    return "\n".join(out)


def write(report: dict, out_dir) -> list[Path]:
    from ...output import write_json_atomic, write_text_atomic

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out / "steppers.json", report, indent=2)
    write_text_atomic(out / "steppers.md", markdown(report))
    return [out / "steppers.json", out / "steppers.md"]
