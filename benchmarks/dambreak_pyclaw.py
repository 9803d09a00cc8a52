"""tiseg against PyClaw on a 2D dam break: error against the exact solution and wall time, over a
resolution ladder, with the two codes alternating (issue 14).

    python benchmarks/dambreak_pyclaw.py --out benchmarks/dambreak [--nx 128 256 512 768 1024]
        [--ref-nx 1024] [--band 960 992 1024 1056 1088]
        [--combos weno+rkc minmod+ssprk4_2+sum ...] [--threads 1 2] [--repeats 3] [--no-pyclaw]

Problem (Stoker): x in [0, 2] m, y in [0, 0.25] m, nx x nx/8 cells, dam at x = 1 m, h_l = 1 m,
h_r = 0.1 m at rest, g = 9.81, flat bed; outflow in x, walls in y; t = 0.14 s. Error: the mean
|h - h_exact| over the cells, h_exact the exact solution's cell averages (tiseg.model.exact_dambreak).
The dry case (Ritter, h_r = 0) runs with ``--case ritter``; PyClaw's Roe solver is run on it too
and its result recorded as it comes (NaN or negative h).

PyClaw (Clawpack 5: Fortran kernels, Roe solver with entropy fix, MC limiter, dimensional
splitting, CFL 0.9, one thread) is an optional extra for this benchmark only: ``pip install
clawpack`` needs gfortran (Debian: ``apt-get install gfortran``). Without it, ``--no-pyclaw``.

Every (code, settings) ladder runs in a fresh process, so tiseg's thread count and Taichi start-
up are those of a user's run; the wall time is the solve alone (from the initial state to t,
after a warm-up run that compiled the grid's kernels, and a reset), and the start-up (import,
Taichi initialisation, kernel compile or cache load, first step) is recorded apart. The best of
``--repeats`` runs counts (these machines are shared and noisy). Rows go to results.csv as they
come (a study resumes where it stopped); results.md and work_precision.png are written from all
rows.

    python benchmarks/dambreak_pyclaw.py --out benchmarks/dambreak/paired --paired 3
        [--band 960 992 1024 1056 1088] [--combos ...] [--threads 1 2]

``--paired ROUNDS`` measures side by side instead: per thread count one process holds PyClaw
and every combo, compiles and warms them on the ``--band`` grids, then solves round after
round, each round every code once per grid in a rotating order. Each round's wall ratio
tiseg / PyClaw (over the band's grids) is one paired measurement, and a load change between
rounds cancels out of it. The band's mean errors set the accuracy ratio (one grid's error moves
by up to 15 % with where the bore falls in its cell). paired.csv holds every solve (whole
rounds, so a study resumes); paired_CASE.md the report.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

LX, LY, X0, HL, HR, T_END = 2.0, 0.25, 1.0, 1.0, 0.1, 0.14
CASES = {"stoker": HR, "ritter": 0.0}

# label -> tiseg [numerics] overrides; "+sum" is step_rule = "sum" at its cfl 0.5
# the numerics each label names, spelt out in full (the dam-break scene's own change over time)
BASE = {"theta": 1.5, "flux": "kt", "step_rule": "max", "cfl": 0.25, "precision": "f64"}
SUM = {"step_rule": "sum", "cfl": 0.5}
SHARP = {"reconstruction": "minmod", "theta": 2.0, "flux": "central-upwind", **SUM}
LOCAL = {**SHARP, "step_rule": "local"}
# the split MUSCL-Hancock sweeps (tiseg.solver.numerics.split): each sweep's own Courant number
HANCOCK = {**SHARP, "stepper": "hancock", "step_rule": "max", "cfl": 0.9}


def _combo(**kw) -> dict:
    return {**BASE, **kw}


COMBOS = {
    # the fingers scene's numerics before issue 14, and with the sum rule
    "weno+rkc": _combo(reconstruction="weno", stepper="rkc"),
    "weno+rkc+sum": _combo(reconstruction="weno", stepper="rkc", **SUM),
    # the dam-break scene's numerics before issue 14
    "minmod+ssprk3": _combo(reconstruction="minmod", stepper="ssprk3"),
    "minmod+ssprk2": _combo(reconstruction="minmod", stepper="ssprk2"),
    "minmod+ssprk4_2+sum": _combo(reconstruction="minmod", stepper="ssprk4_2", **SUM),
    # the dam-break scene's numerics after issue 14: minmod2+cu+ssprk4_2+sum
    "minmod2+cu+ssprk4_2+sum": _combo(stepper="ssprk4_2", **SHARP),
    "minmod2+cu+ssprk10_4+sum": _combo(stepper="ssprk10_4", **SHARP),
    "minmod2+cu+ssprk10_2+sum": _combo(stepper="ssprk10_2", **SHARP),
    "minmod2+cu+ssprk9_3+sum": _combo(stepper="ssprk9_3", **SHARP),
    "minmod2+cu+ssprk16_3+sum": _combo(stepper="ssprk16_3", **SHARP),
    "minmod2+cu+ssprk4_2+sum+f32": _combo(stepper="ssprk4_2", **SHARP, precision="f32"),
    # the local sum rule (the dam-break scene's numerics from session 12 on)
    "minmod2+cu+ssprk4_2+local": _combo(stepper="ssprk4_2", **LOCAL),
    "minmod2+cu+ssprk16_3+local": _combo(stepper="ssprk16_3", **LOCAL),
    "minmod2+cu+ssprk10_4+local": _combo(stepper="ssprk10_4", **LOCAL),
    "minmod2+cu+ssprk10_2+sum+f32": _combo(stepper="ssprk10_2", **SHARP, precision="f32"),
    # dimensionally split MUSCL-Hancock sweeps (the dam-break scene's numerics from session 13)
    "minmod2+cu+hancock": _combo(**HANCOCK),
    "minmod2+cu+hancock+cfl0.75": _combo(**{**HANCOCK, "cfl": 0.75}),
    "minmod2+cu+hancock+cfl0.6": _combo(**{**HANCOCK, "cfl": 0.6}),
    "minmod2+cu+hancock+cfl0.5": _combo(**{**HANCOCK, "cfl": 0.5}),
}
DEFAULT_COMBOS = (
    "weno+rkc",
    "weno+rkc+sum",
    "minmod+ssprk3",
    "minmod+ssprk4_2+sum",
    "minmod2+cu+ssprk4_2+sum",
    "minmod2+cu+ssprk10_4+sum",
    "minmod2+cu+ssprk10_2+sum",
    "minmod2+cu+ssprk9_3+sum",
    "minmod2+cu+ssprk16_3+sum",
    "minmod2+cu+ssprk4_2+sum+f32",
)
# what one solve reports (tiseg_solve, pyclaw_solve), and the csv columns around it
SOLVE_FIELDS = ("nx", "cells", "error", "h_min", "steps", "rhs_evals", "wall_s")
COLUMNS = ("case", "code", "combo", "threads", *SOLVE_FIELDS, "startup_s", "repeat")


def exact_h(case: str, x: np.ndarray, dx: float) -> np.ndarray:
    from tiseg.model.exact_dambreak import cell_averages, ritter, stoker

    if case == "ritter":
        f = lambda p: ritter(p, T_END, HL, X0)[0]  # noqa: E731
    else:
        f = lambda p: stoker(p, T_END, HL, HR, X0)[0]  # noqa: E731
    return cell_averages(f, x, dx)


# ---- one solve of each code --------------------------------------------------------------------
def tiseg_build(case: str, combo: str, nx: int, threads: int):
    """(scene, Simulation) of the problem on nx x nx/8 cells with the combo's numerics."""
    from tiseg.setup.scene import load_scene
    from tiseg.run.simulation import Simulation

    over = {
        "domain.Lx": LX,
        "domain.Ly": LY,
        "domain.nx": nx,
        "domain.ny": max(nx // 8, 1),
        "boundary.y_lo": "wall",
        "boundary.y_hi": "wall",
        "flow.h0": HL,
        "initial.x0": X0,
        "initial.h_left": HL,
        "initial.h_right": CASES[case],
        "numerics.h_min": 1e-6,
        "numerics.h_eps": 1e-9,
        "time.t_end": T_END,
        "output.interval": T_END,
        **{f"numerics.{key}": v for key, v in COMBOS[combo].items()},
    }
    sc = load_scene("dam-break", over)
    return sc, Simulation(sc, threads=threads)


def tiseg_solve(case: str, sc, sim) -> dict:
    """Reset to the initial state and solve to T_END: the row of that solve."""
    sim.reset()
    t1 = time.perf_counter()
    sim.advance(T_END)
    wall = time.perf_counter() - t1
    h = sim.fields()["h"]
    x, _ = sc.domain.cell_centres()
    err = float(np.mean(np.abs(h - exact_h(case, x, sc.dx)[None, :])))  # h is (ny, nx)
    return {
        "nx": sc.domain.nx,
        "cells": h.size,
        "error": err,
        "h_min": float(h.min()),
        "steps": sim.stats.steps,
        "rhs_evals": sim.stats.stages,
        "wall_s": wall,
        "startup_s": math.nan,
    }


def pyclaw_solve(case: str, nx: int) -> dict:
    """Build PyClaw's solver and solve to T_END (the build is timed as part of the run, as
    it always was: it is small against the solve)."""
    from clawpack import pyclaw, riemann

    solver = pyclaw.ClawSolver2D(riemann.shallow_roe_with_efix_2D)
    solver.limiters = pyclaw.limiters.tvd.MC
    solver.dimensional_split = True
    solver.cfl_desired, solver.cfl_max = 0.9, 1.0
    solver.bc_lower[0] = solver.bc_upper[0] = pyclaw.BC.extrap
    solver.bc_lower[1] = solver.bc_upper[1] = pyclaw.BC.wall
    xd = pyclaw.Dimension(0.0, LX, nx, name="x")
    yd = pyclaw.Dimension(0.0, LY, max(nx // 8, 1), name="y")
    domain = pyclaw.Domain([xd, yd])
    state = pyclaw.State(domain, 3)
    state.problem_data["grav"] = 9.81
    X, _ = state.grid.p_centers
    state.q[0] = np.where(X < X0, HL, CASES[case])
    state.q[1] = state.q[2] = 0.0
    claw = pyclaw.Controller()
    claw.solution = pyclaw.Solution(state, domain)
    claw.solver, claw.tfinal, claw.num_output_times = solver, T_END, 1
    claw.output_format, claw.keep_copy, claw.verbosity = None, True, 0
    t1 = time.perf_counter()
    with np.errstate(all="ignore"):
        claw.run()
    wall = time.perf_counter() - t1
    h = claw.frames[-1].q[0]
    x = (np.arange(nx) + 0.5) * (LX / nx)
    err = float(np.mean(np.abs(h - exact_h(case, x, LX / nx)[:, None])))
    return {
        "nx": nx,
        "cells": h.size,
        "error": err,
        "h_min": float(np.nanmin(h)) if np.isfinite(h).any() else math.nan,
        "steps": solver.status["numsteps"],
        "rhs_evals": math.nan,
        "wall_s": wall,
        "startup_s": math.nan,
    }


# ---- workers (one per process) ------------------------------------------------------------------
def tiseg_ladder(case: str, combo: str, threads: int, nxs: list[int]) -> list[dict]:
    t0 = time.perf_counter()
    from tiseg import backend

    backend.init("cpu", COMBOS[combo].get("precision", "f64"), threads)
    rows = []
    for k, nx in enumerate(nxs):
        sc, sim = tiseg_build(case, combo, nx, threads)
        sim.step(T_END)
        if k == 0:  # start-up: everything up to the end of the first step
            startup = time.perf_counter() - t0
        # a whole warm-up run compiles every kernel of this grid (Taichi specialises them per
        # operator; the guard's kernels first run at step 10): the timed run is all solve
        sim.advance(T_END)
        row = tiseg_solve(case, sc, sim)
        row["startup_s"] = startup if k == 0 else math.nan
        rows.append(row)
    return rows


def pyclaw_ladder(case: str, nxs: list[int]) -> list[dict]:
    t0 = time.perf_counter()
    from clawpack import pyclaw, riemann  # noqa: F401

    startup = time.perf_counter() - t0
    rows = []
    for nx in nxs:
        row = pyclaw_solve(case, nx)
        row["startup_s"] = startup if not rows else math.nan
        rows.append(row)
    return rows


def paired_rounds(
    case: str, combos: list[str], threads: int, nxs: list[int], rounds: int, first: int = 0
):
    """Both codes in this one process, alternating solve by solve: for each round and grid,
    PyClaw and every combo solve once, in an order that rotates from round to round. A load
    change on a shared machine then hits both codes of a round alike, and the ratio of their
    walls within a round is the side-by-side measure. Yields one row per solve."""
    from tiseg import backend

    precisions = {COMBOS[c].get("precision", "f64") for c in combos}
    if len(precisions) > 1:
        raise SystemExit("--paired: Taichi's precision is process-wide; give combos of one")
    backend.init("cpu", precisions.pop(), threads)
    sims = {}
    for c in combos:  # compile and warm every grid first
        for nx in nxs:
            sc, sim = tiseg_build(case, c, nx, threads)
            sim.advance(T_END)
            sims[c, nx] = (sc, sim)
    pyclaw_solve(case, nxs[0])  # PyClaw's import and first solve
    runners = [("pyclaw", "roe+mc")] + [("tiseg", c) for c in combos]
    for rnd in range(first, rounds):
        for nx in nxs:
            k = (rnd + nx) % len(runners)
            for code, combo in runners[k:] + runners[:k]:
                if code == "pyclaw":
                    row = pyclaw_solve(case, nx)
                else:
                    row = tiseg_solve(case, *sims[combo, nx])
                yield {"code": code, "combo": combo, "round": rnd, **row}


# ---- driver -------------------------------------------------------------------------------------
PAIRED_COLUMNS = ("case", "threads", "round", "code", "combo", *SOLVE_FIELDS)


def _worker_main(argv: list[str]) -> None:
    spec = json.loads(argv[0])
    if spec["code"] == "paired":  # whole rounds go to the csv as they end (a study resumes)
        path = Path(spec["csv"])
        new = not path.exists()
        with path.open("a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=PAIRED_COLUMNS, extrasaction="ignore")
            if new:
                w.writeheader()
            held: list[dict] = []
            args = [spec[k] for k in ("case", "combos", "threads", "nx", "rounds", "first_round")]
            for row in paired_rounds(*args):
                if held and row["round"] != held[-1]["round"]:
                    w.writerows(held)
                    f.flush()
                    held = []
                held.append({**row, "case": spec["case"], "threads": spec["threads"]})
                print(
                    f"round {row['round']} {row['code']} {row['combo']} nx={row['nx']}: "
                    f"error {row['error']:.3e}, wall {row['wall_s']:.3f} s",
                    flush=True,
                )
            w.writerows(held)
        return
    if spec["code"] == "pyclaw":
        rows = pyclaw_ladder(spec["case"], spec["nx"])
    else:
        rows = tiseg_ladder(spec["case"], spec["combo"], spec["threads"], spec["nx"])
    print("ROWS " + json.dumps(rows))


def run_ladder(spec: dict, cwd: Path) -> list[dict]:
    """One ladder in a fresh process, run in ``cwd`` (PyClaw writes its pyclaw.log there)."""
    me = str(Path(__file__).resolve())
    p = subprocess.run(
        [sys.executable, me, "--worker", json.dumps(spec)], capture_output=True, text=True, cwd=cwd
    )
    for line in p.stdout.splitlines():
        if line.startswith("ROWS "):
            return json.loads(line[5:])
    raise RuntimeError(f"{spec}: worker failed\n{p.stderr[-2000:]}")


def read_rows(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with path.open() as f:
        return list(csv.DictReader(f))


def best(rows: list[dict]) -> dict[tuple, dict]:
    """(case, code, combo, threads, nx) -> the row of the fastest repeat."""
    out: dict[tuple, dict] = {}
    for r in rows:
        key = (r["case"], r["code"], r["combo"], int(r["threads"]), int(r["nx"]))
        if key not in out or float(r["wall_s"]) < float(out[key]["wall_s"]):
            keep = dict(r)
            starts = [float(q["startup_s"]) for q in rows if _same(q, r) and q["startup_s"]]
            starts = [s for s in starts if math.isfinite(s)]
            keep["startup_s"] = min(starts) if starts else math.nan
            out[key] = keep
    return out


def _same(a: dict, b: dict) -> bool:
    return all(a[k] == b[k] for k in ("case", "code", "combo", "threads"))


def _interp_loglog(xs, ys, x) -> tuple[float, bool]:
    """(y at x on the piecewise log-log line through (xs, ys), extrapolated?): beyond the
    points the line through the last two is continued (marked, and at most one ladder step
    of a factor 2 in nx, i.e. about 8x in wall time, else NaN)."""
    lx, ly = np.log(np.asarray(xs, float)), np.log(np.asarray(ys, float))
    order = np.argsort(lx)
    lx, ly = lx[order], ly[order]
    lt = math.log(x)
    if lx[0] <= lt <= lx[-1]:
        return float(np.exp(np.interp(lt, lx, ly))), False
    i, j = (0, 1) if lt < lx[0] else (-2, -1)
    reach = lx[j] - lx[i]
    if len(lx) < 2 or abs(lt - lx[j if lt > lx[-1] else i]) > reach:
        return math.nan, True
    slope = (ly[j] - ly[i]) / (lx[j] - lx[i])
    base = j if lt > lx[-1] else i
    return float(np.exp(ly[base] + slope * (lt - lx[base]))), True


def summary(rows: list[dict], case: str, ref_nx: int) -> list[str]:
    """Markdown: per ladder, the wall time to PyClaw's error at ref_nx and the error at PyClaw's
    wall time there, each as a ratio to PyClaw's (log-log interpolation along the ladder)."""
    b = best([r for r in rows if r["case"] == case])
    lines = [
        f"Case {case}: error = mean |h - h_exact| [m] at t = {T_END} s; wall = solve time [s]",
        "(best of the repeats); start-up = import to end of the first step [s].",
        "",
        "| code | settings | threads | nx | error | steps | evaluations | wall s | start-up s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for key in sorted(b, key=lambda k: (k[1] != "pyclaw", k[2], k[3], k[4])):
        r = b[key]
        lines.append(
            f"| {r['code']} | {r['combo']} | {r['threads']} | {r['nx']} | "
            f"{float(r['error']):.3e} | {r['steps']} | {r['rhs_evals']} | "
            f"{float(r['wall_s']):.3f} | {float(r['startup_s']):.2f} |"
        )
    ref = b.get((case, "pyclaw", "roe+mc", 1, ref_nx))
    if ref is None or not math.isfinite(float(ref["error"])):
        return lines
    e_ref, w_ref = float(ref["error"]), float(ref["wall_s"])
    lines += [
        "",
        f"Against PyClaw at nx = {ref_nx} (error {e_ref:.3e}, wall {w_ref:.3f} s):",
        "",
        "| settings | threads | wall to PyClaw's error / PyClaw's | error at PyClaw's wall / PyClaw's |",
        "|---|---|---|---|",
    ]
    ladders: dict[tuple, list[dict]] = {}
    for key, r in b.items():
        if key[1] == "tiseg":
            ladders.setdefault((key[2], key[3]), []).append(r)
    for (combo, th), rs in sorted(ladders.items()):
        rs.sort(key=lambda r: int(r["nx"]))
        errs = [float(r["error"]) for r in rs]
        walls = [float(r["wall_s"]) for r in rs]
        w_at, w_ex = _interp_loglog(errs, walls, e_ref)
        e_at, e_ex = _interp_loglog(walls, errs, w_ref)
        lines.append(
            f"| {combo} | {th} | {'~' * w_ex}{w_at / w_ref:.2f} | {'~' * e_ex}{e_at / e_ref:.2f} |"
        )
    lines += ["", "~: extrapolated along the last two points of the ladder (log-log)."]
    return lines


def band_summary(rows: list[dict], case: str, band: list[int]) -> list[str]:
    """Markdown: each code's mean error and mean wall time over the grids of ``band`` (those
    every ladder has), against PyClaw's on the same grids.

    Why a band: where the bore falls within its cell moves the error by up to +-15 % for tiseg
    and +-5 % for PyClaw from one grid to the next (1040 cells: 3.17e-4 against 2.58e-4; 1056:
    2.36e-4 against 2.43e-4), more than the differences being measured. Averaged over a few
    neighbouring grids that scatter cancels. The wall time at equal error is then estimated
    as wall ratio x (error ratio)^3: the error of a bore falls as 1/nx (measured: order 1.0-1.1
    from 512 to 1024 cells, both codes) and the work grows as nx^3 (cells x steps)."""
    b = best([r for r in rows if r["case"] == case])
    ladders: dict[tuple, dict[int, dict]] = {}
    for key, r in b.items():
        ladders.setdefault((key[1], key[2], key[3]), {})[key[4]] = r
    ref = ladders.get(("pyclaw", "roe+mc", 1))
    if ref is None:
        return []
    grids = [n for n in band if n in ref and all(n in g for g in ladders.values())]
    if len(grids) < 2:
        return []

    def mean(ls: dict, col: str) -> float:
        return float(np.mean([float(ls[n][col]) for n in grids]))

    e_ref, w_ref = mean(ref, "error"), mean(ref, "wall_s")
    lines = [
        "",
        f"Mean over the grids nx = {', '.join(map(str, grids))} (PyClaw: error {e_ref:.3e}, "
        f"wall {w_ref:.3f} s):",
        "",
        "| code | settings | threads | mean error | error / PyClaw's | mean wall s "
        "| wall / PyClaw's | wall at PyClaw's error / PyClaw's (est.) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for (code, combo, th), ls in sorted(
        ladders.items(), key=lambda kv: (kv[0][0] != "pyclaw", kv[0])
    ):
        e, w = mean(ls, "error"), mean(ls, "wall_s")
        lines.append(
            f"| {code} | {combo} | {th} | {e:.3e} | {e / e_ref:.3f} | {w:.3f} | "
            f"{w / w_ref:.2f} | {w / w_ref * (e / e_ref) ** 3:.2f} |"
        )
    return lines


def paired_summary(rows: list[dict], case: str, band: list[int]) -> list[str]:
    """Markdown of a --paired study: per grid each solve's error and median wall over the
    rounds; then, per combo and thread count, the median over rounds of the wall ratio to
    PyClaw's in that round (summed over the band's grids), the ratio of the mean errors over
    the band, and the wall at PyClaw's error estimated from the two (band_summary)."""
    rows = [r for r in rows if r["case"] == case]
    if not rows:
        return []
    walls: dict[tuple, list[float]] = {}
    errs: dict[tuple, float] = {}
    per_round: dict[tuple, float] = {}
    for r in rows:
        key = (int(r["threads"]), r["code"], r["combo"], int(r["nx"]))
        walls.setdefault(key, []).append(float(r["wall_s"]))
        errs[key] = float(r["error"])
        rk = (int(r["threads"]), r["code"], r["combo"], int(r["round"]))
        if int(r["nx"]) in band:
            per_round[rk] = per_round.get(rk, 0.0) + float(r["wall_s"])
    lines = [
        f"Paired study, case {case}: PyClaw and tiseg in one process per thread count, "
        "alternating solve by solve (wall: median over the rounds).",
        "",
        "| threads | code | settings | nx | error | wall s (median) | rounds |",
        "|---|---|---|---|---|---|---|",
    ]
    for key in sorted(walls, key=lambda k: (k[0], k[1] != "pyclaw", k[2], k[3])):
        th, code, combo, nx = key
        lines.append(
            f"| {th} | {code} | {combo} | {nx} | {errs[key]:.3e} | "
            f"{float(np.median(walls[key])):.3f} | {len(walls[key])} |"
        )
    lines += [
        "",
        f"Over the grids {', '.join(map(str, band))}: wall ratio = median over rounds of "
        "(tiseg's walls summed over the grids) / (PyClaw's, same round); error ratio = mean "
        "error / PyClaw's mean error; at equal error (est.) = wall ratio x error ratio^3.",
        "",
        "| threads | settings | rounds | wall / PyClaw's (median, range) | error / PyClaw's "
        "| wall at PyClaw's error / PyClaw's (est.) |",
        "|---|---|---|---|---|---|",
    ]
    for th in sorted({k[0] for k in walls}):
        e_ref = [errs.get((th, "pyclaw", "roe+mc", n)) for n in band]
        if any(e is None for e in e_ref):
            continue
        for combo in sorted({k[2] for k in walls if k[0] == th and k[1] == "tiseg"}):
            e = [errs.get((th, "tiseg", combo, n)) for n in band]
            if any(x is None for x in e):
                continue
            ratios = [
                w / per_round[(th, "pyclaw", "roe+mc", rnd)]
                for (t2, code, c2, rnd), w in per_round.items()
                if t2 == th
                and code == "tiseg"
                and c2 == combo
                and (th, "pyclaw", "roe+mc", rnd) in per_round
            ]
            if not ratios:
                continue
            er = float(np.mean(e)) / float(np.mean(e_ref))
            wr = float(np.median(ratios))
            lines.append(
                f"| {th} | {combo} | {len(ratios)} | {wr:.3f} ({min(ratios):.3f}-"
                f"{max(ratios):.3f}) | {er:.3f} | {wr * er**3:.2f} |"
            )
    return lines


def plot(rows: list[dict], case: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    b = best([r for r in rows if r["case"] == case])
    ladders: dict[tuple, list[dict]] = {}
    for key, r in b.items():
        ladders.setdefault((key[1], key[2], key[3]), []).append(r)
    fig, ax = plt.subplots(figsize=(10, 5.5))
    combos = sorted({k[1] for k in ladders if k[0] == "tiseg"})
    colours = {c: plt.get_cmap("tab10")(i % 10) for i, c in enumerate(combos)}
    for (code, combo, th), rs in sorted(ladders.items()):
        rs.sort(key=lambda r: int(r["nx"]))
        w = [float(r["wall_s"]) for r in rs]
        e = [float(r["error"]) for r in rs]
        if code == "pyclaw":
            style = dict(color="k", lw=2.5, marker="s")
        else:  # one colour per numerics, solid on 2 threads, dashed on 1
            style = dict(color=colours[combo], marker="o", ms=4, ls="-" if int(th) > 1 else "--")
        ax.loglog(w, e, label=f"{code} {combo} ({th} thr)", **style)
        for r, wi, ei in zip(rs, w, e):
            if code == "pyclaw":
                ax.annotate(
                    r["nx"], (wi, ei), fontsize=7, textcoords="offset points", xytext=(4, 4)
                )
    ax.set_xlabel("wall time of the solve [s]")
    ax.set_ylabel("mean |h - h_exact| [m]")
    ax.set_title(f"2D dam break ({case}), t = {T_END} s: work against precision")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=Path("benchmarks/dambreak"))
    p.add_argument("--case", choices=tuple(CASES), default="stoker")
    p.add_argument("--nx", type=int, nargs="+", default=[128, 256, 512, 768, 1024])
    p.add_argument("--combos", nargs="+", choices=tuple(COMBOS), default=list(DEFAULT_COMBOS))
    p.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    p.add_argument(
        "--ref-nx", type=int, default=None, help="PyClaw's grid to compare at (default: largest)"
    )
    p.add_argument(
        "--band",
        type=int,
        nargs="+",
        default=[960, 992, 1024, 1056, 1088],
        help="grids whose mean error and wall the report compares (those run)",
    )
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--no-pyclaw", action="store_true", help="tiseg alone")
    p.add_argument("--report-only", action="store_true", help="rewrite results.md and the plot")
    p.add_argument(
        "--paired",
        type=int,
        metavar="ROUNDS",
        help="instead of ladders: PyClaw and the combos alternating in one process per thread "
        "count, ROUNDS rounds over the --band grids; paired.csv and paired_CASE.md",
    )
    p.add_argument("--worker", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        _worker_main([args.worker])
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    if args.paired:
        return paired_main(args)
    csv_path = args.out / "results.csv"
    rows = read_rows(csv_path)
    if not args.report_only:
        specs = [] if args.no_pyclaw else [{"code": "pyclaw", "combo": "roe+mc", "threads": 1}]
        specs += [
            {"code": "tiseg", "combo": c, "threads": t} for c in args.combos for t in args.threads
        ]
        new = not csv_path.exists()
        with csv_path.open("a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=COLUMNS)
            if new:
                w.writeheader()
            for rep in range(args.repeats):  # the codes alternate within each repeat
                for spec in specs:
                    done = {
                        int(r["nx"])
                        for r in rows
                        if _same(r, {**spec, "case": args.case}) and int(r["repeat"]) == rep
                    }
                    todo = [n for n in args.nx if n not in done]
                    if not todo:
                        continue  # resumed: this repeat of this ladder is on record
                    spec = {**spec, "case": args.case, "nx": todo}
                    got = run_ladder(spec, args.out)
                    for r in got:
                        row = {**{k: spec[k] for k in ("case", "code", "combo", "threads")}}
                        row.update(r, repeat=rep)
                        w.writerow(row)
                        rows.append({k: str(v) for k, v in row.items()})
                        print(
                            f"{args.case} {spec['code']} {spec['combo']} {spec['threads']} thr "
                            f"nx={r['nx']}: error {r['error']:.3e}, wall {r['wall_s']:.3f} s",
                            flush=True,
                        )
                    f.flush()
    ref_nx = args.ref_nx or max(int(r["nx"]) for r in rows if r["case"] == args.case)
    md = summary(rows, args.case, ref_nx) + band_summary(rows, args.case, args.band)
    (args.out / f"results_{args.case}.md").write_text("\n".join(md) + "\n")
    plot(rows, args.case, args.out / f"work_precision_{args.case}.png")
    print("\n".join(md))
    return 0


def paired_main(args) -> int:
    csv_path = args.out / "paired.csv"
    if not args.report_only:
        for th in args.threads:
            rows = [
                r for r in read_rows(csv_path) if r["case"] == args.case and int(r["threads"]) == th
            ]
            # the rounds on record (the worker writes whole rounds)
            per_round = len(args.band) * (1 + len(args.combos))
            rounds = [int(r["round"]) for r in rows]
            complete = {k for k in set(rounds) if rounds.count(k) == per_round}
            first = max(complete) + 1 if complete else 0
            if first >= args.paired:
                continue
            spec = {
                "code": "paired",
                "case": args.case,
                "combos": list(args.combos),
                "threads": th,
                "nx": list(args.band),
                "rounds": args.paired,
                "first_round": first,
                "csv": str(csv_path.resolve()),
            }
            me = str(Path(__file__).resolve())
            p = subprocess.run([sys.executable, me, "--worker", json.dumps(spec)], cwd=args.out)
            if p.returncode:
                raise SystemExit(f"paired worker for {th} thread(s) failed")
    md = paired_summary(read_rows(csv_path), args.case, list(args.band))
    (args.out / f"paired_{args.case}.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
