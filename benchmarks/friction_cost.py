"""Cost of the friction laws and schemes (issue 15, part 6), in two parts.

1. Per step, on the fingers scene (default 250 cells/m to t = 4 s): the four (law, scheme)
   pairs below run side by side in one process, each advanced by the same 0.05 s of
   simulated time in turn (the order rotating), so that the machine's load falls on all of
   them alike; compilation and the first 0.05 s are outside the timing. Ratios are against
   the paper's set-up (pouliquen-mixture, regularised) of the same round; the median over the
   rounds is reported. Written to benchmarks/friction/cost.csv and cost.md.
2. Regions at rest, on the finite-release-deposit scene (default 250 cells/m to t = 120 s):
   the same run with and without skipping the columns held at rest (Simulation's
   ``skip_rest``), advanced in 5 s reports in turn; wall time, steps and the computed share
   of the wet columns per report. Written to benchmarks/friction/rest.csv and rest.md.

A benchmark, not a test: run it on a quiet machine,

    python benchmarks/friction_cost.py [--resolution 250] [--t-end 4] [--repeats 3]
        [--deposit-resolution 250] [--deposit-t-end 120] [--skip-deposit]
"""

from __future__ import annotations

import argparse
import csv
import platform
import statistics
import time
from pathlib import Path

CASES = (
    ("pouliquen-mixture", "regularised"),
    ("pouliquen-mixture", "projected"),
    ("pouliquen-extended", "regularised"),
    ("pouliquen-extended", "projected"),
)
CHUNK = 0.05  # [s] of simulated time each case advances in turn
OUT = Path(__file__).resolve().parent / "friction"


def _machine() -> str:
    """The CPU's model name (Linux) or the platform's, the system and the core count."""
    import os

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return f"{cpu}, {platform.system()}, {os.cpu_count()} cores"


def _fingers(law, scheme, resolution, t_end):
    from tiseg.setup.scene import load_scene
    from tiseg.run.simulation import Simulation

    sc = load_scene(
        "fingers",
        {
            "domain.resolution": resolution,
            "time.t_end": t_end,
            "effects.friction": law,
            "numerics.friction_scheme": scheme,
            "output.times": [],
        },
    )
    return Simulation(sc)


def per_step_round(rnd, resolution, t_end):
    """One round of part 1: the four cases interleaved; one row per case."""
    sims = [_fingers(law, scheme, resolution, t_end) for law, scheme in CASES]
    for sim in sims:
        sim.advance(CHUNK)  # compilation and the first steps, outside the timing
    s0 = [(sim.stats.steps, sim.stats.stages) for sim in sims]
    wall = [0.0] * len(sims)
    n = round(t_end / CHUNK)
    for c in range(2, n + 1):
        for m in range(len(sims)):
            k = (m + c) % len(sims)  # rotate who goes first
            t0 = time.perf_counter()
            sims[k].advance(min(c * CHUNK, t_end))
            wall[k] += time.perf_counter() - t0
    rows = []
    for k, (law, scheme) in enumerate(CASES):
        steps = sims[k].stats.steps - s0[k][0]
        evals = sims[k].stats.stages - s0[k][1]
        rows.append(
            dict(
                round=rnd,
                law=law,
                scheme=scheme,
                wall_s=round(wall[k], 3),
                steps=steps,
                evaluations=evals,
                ms_per_step=round(1e3 * wall[k] / steps, 4),
                ms_per_evaluation=round(1e3 * wall[k] / evals, 4),
            )
        )
    base = rows[0]
    for r in rows:
        r["ratio_per_step"] = round(r["ms_per_step"] / base["ms_per_step"], 3)
        r["ratio_per_evaluation"] = round(r["ms_per_evaluation"] / base["ms_per_evaluation"], 3)
        r["ratio_wall"] = round(r["wall_s"] / base["wall_s"], 3)
    return rows


def _write_csv(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def per_step(a) -> None:
    rows = []
    for rnd in range(a.repeats):
        for r in per_step_round(rnd, a.resolution, a.t_end):
            print(r, flush=True)
            rows.append(r)
    _write_csv(OUT / "cost.csv", rows)
    lines = [
        f"# Friction cost per step: fingers scene, {a.resolution:g} cells/m, to t = {a.t_end:g} s",
        "",
        f"Machine: {_machine()}. The four cases run side by side in one process, each advanced "
        f"by {CHUNK:g} s of simulated time in turn; ratios against pouliquen-mixture + "
        "regularised of the same round (`python benchmarks/friction_cost.py`).",
        "",
        "| round | law | scheme | wall [s] | steps | evaluations | ms/step | ms/evaluation | "
        "per-step ratio | per-evaluation ratio | wall ratio |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['round']} | {r['law']} | {r['scheme']} | {r['wall_s']} | {r['steps']} | "
            f"{r['evaluations']} | {r['ms_per_step']} | {r['ms_per_evaluation']} | "
            f"{r['ratio_per_step']} | {r['ratio_per_evaluation']} | {r['ratio_wall']} |"
        )
    lines += [
        "",
        f"Median over the {a.repeats} rounds:",
        "",
        "| law | scheme | per-step ratio | per-evaluation ratio | wall ratio |",
        "|---|---|---|---|---|",
    ]
    for law, scheme in CASES:
        mine = [r for r in rows if (r["law"], r["scheme"]) == (law, scheme)]
        med = {
            k: statistics.median(r[k] for r in mine)
            for k in ("ratio_per_step", "ratio_per_evaluation", "ratio_wall")
        }
        lines.append(
            f"| {law} | {scheme} | {med['ratio_per_step']:.3f} | "
            f"{med['ratio_per_evaluation']:.3f} | {med['ratio_wall']:.3f} |"
        )
    (OUT / "cost.md").write_text("\n".join(lines) + "\n")


def rest_skipping(a) -> None:
    """Part 2: the deposit scene with and without skipping the regions held at rest."""
    from tiseg.setup.scene import load_scene
    from tiseg.run.simulation import Simulation

    sc = load_scene(
        "finite-release-deposit",
        {
            "domain.resolution": a.deposit_resolution,
            "time.t_end": a.deposit_t_end,
            "output.times": [],
        },
    )
    sims = {"skip": Simulation(sc), "full": Simulation(sc, skip_rest=False)}
    rows = []
    report = 5.0
    n = round(a.deposit_t_end / report)
    for c in range(1, n + 1):
        t = min(c * report, a.deposit_t_end)
        order = ("skip", "full") if c % 2 else ("full", "skip")
        row = {"t": t}
        for name in order:
            sim = sims[name]
            s0 = sim.stats.steps
            t0 = time.perf_counter()
            sim.advance(t)
            row[f"{name}_wall_s"] = round(time.perf_counter() - t0, 3)
            row[f"{name}_steps"] = sim.stats.steps - s0
        op = sims["skip"].op
        (lo, hi), (wa, wb) = op.active, op.wet_range
        row["computed_share"] = round((hi - lo) / max(wb - wa, 1), 3)
        q = sims["skip"].conserved()
        row["moving_cells"] = int((q[1] != 0).sum())
        print(row, flush=True)
        rows.append(row)
    _write_csv(OUT / "rest.csv", rows)
    qs, qf = sims["skip"].conserved(), sims["full"].conserved()
    dh = float(abs(qs[0] - qf[0]).max())
    same = "the same bits" if (qs == qf).all() else f"max |h_skip - h_full| = {dh:.3g} m"
    tot = {
        k: sum(r[k] for r in rows)
        for k in ("skip_wall_s", "full_wall_s", "skip_steps", "full_steps")
    }
    lines = [
        f"# Regions at rest: finite-release-deposit, {a.deposit_resolution:g} cells/m, "
        f"to t = {a.deposit_t_end:g} s",
        "",
        f"Machine: {_machine()}. The same run with and without skipping the columns held at "
        "rest, advanced report by report in turn (the first report includes compilation). "
        "computed share: the active x range over the wet one at the end of the report (skip "
        "run); moving cells: cells with hu != 0 then.",
        "",
        "| t [s] | wall skip [s] | wall full [s] | steps skip | steps full | computed share | "
        "moving cells |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['t']:g} | {r['skip_wall_s']} | {r['full_wall_s']} | {r['skip_steps']} | "
            f"{r['full_steps']} | {r['computed_share']} | {r['moving_cells']} |"
        )
    lines += [
        f"| total | {tot['skip_wall_s']:.1f} | {tot['full_wall_s']:.1f} | {tot['skip_steps']} | "
        f"{tot['full_steps']} | | |",
        "",
        f"Final states of the two runs: {same}.",
    ]
    (OUT / "rest.md").write_text("\n".join(lines) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--resolution", type=float, default=250.0)
    ap.add_argument("--t-end", type=float, default=4.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--deposit-resolution", type=float, default=250.0)
    ap.add_argument("--deposit-t-end", type=float, default=120.0)
    ap.add_argument("--skip-deposit", action="store_true", help="part 1 only")
    ap.add_argument("--skip-per-step", action="store_true", help="part 2 only")
    a = ap.parse_args()
    OUT.mkdir(exist_ok=True)
    if not a.skip_per_step:
        per_step(a)
    if not a.skip_deposit:
        rest_skipping(a)


if __name__ == "__main__":
    main()
