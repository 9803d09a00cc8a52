"""Cost of the friction laws and schemes on the fingers scene (issue 15, part 6).

Runs the fingers scene at 250 cells/m to t = 4 s for each (law, scheme) in turn, alternating,
and writes benchmarks/friction/cost.csv and cost.md: wall time of the stepping, steps, operator
evaluations and the time per evaluation, with the ratio to the paper's set-up
(pouliquen-mixture, regularised) of the same round, and the median ratio over the rounds.
Compilation is excluded: a first round that is not recorded compiles every kernel variant the
runs meet (RKC compiles one per stage shape, some only late in a run). A benchmark, not a test:
run it on a quiet machine,

    python benchmarks/friction_cost.py [--resolution 250] [--t-end 4] [--repeats 5]
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
OUT = Path(__file__).resolve().parent / "friction"


def run_case(law, scheme, resolution, t_end):
    from tiseg.scene import load_scene
    from tiseg.simulation import Simulation

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
    sim = Simulation(sc)
    sim.advance(0.05)  # compilation and the first steps, outside the timing
    s0, e0 = sim.stats.steps, sim.stats.stages
    t0 = time.perf_counter()
    sim.advance(t_end)
    wall = time.perf_counter() - t0
    steps, evals = sim.stats.steps - s0, sim.stats.stages - e0
    return dict(
        law=law,
        scheme=scheme,
        wall_s=round(wall, 3),
        steps=steps,
        evaluations=evals,
        ms_per_evaluation=round(1e3 * wall / evals, 4),
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--resolution", type=float, default=250.0)
    ap.add_argument("--t-end", type=float, default=4.0)
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    for law, scheme in CASES:  # the unrecorded round: every kernel variant compiled
        run_case(law, scheme, a.resolution, a.t_end)
    rows = []
    for rep in range(a.repeats):
        base = None
        for law, scheme in CASES:
            r = run_case(law, scheme, a.resolution, a.t_end)
            base = base or r
            r.update(round=rep, ratio_wall=round(r["wall_s"] / base["wall_s"], 3))
            r["ratio_per_evaluation"] = round(r["ms_per_evaluation"] / base["ms_per_evaluation"], 3)
            print(r, flush=True)
            rows.append(r)
    OUT.mkdir(exist_ok=True)
    with open(OUT / "cost.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [
        f"# Friction cost: fingers scene, {a.resolution:g} cells/m, to t = {a.t_end:g} s",
        "",
        f"Machine: {platform.processor() or platform.machine()}, {platform.system()}; "
        "ratios against pouliquen-mixture + regularised of the same round.",
        "",
        "| round | law | scheme | wall [s] | steps | evaluations | ms/evaluation | "
        "wall ratio | per-evaluation ratio |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['round']} | {r['law']} | {r['scheme']} | {r['wall_s']} | {r['steps']} | "
            f"{r['evaluations']} | {r['ms_per_evaluation']} | {r['ratio_wall']} | "
            f"{r['ratio_per_evaluation']} |"
        )
    lines += [
        "",
        f"Median over the {a.repeats} rounds:",
        "",
        "| law | scheme | wall ratio | per-evaluation ratio |",
        "|---|---|---|---|",
    ]
    for law, scheme in CASES:
        mine = [r for r in rows if (r["law"], r["scheme"]) == (law, scheme)]
        med = {
            k: statistics.median(r[k] for r in mine) for k in ("ratio_wall", "ratio_per_evaluation")
        }
        lines.append(
            f"| {law} | {scheme} | {med['ratio_wall']:.3f} | {med['ratio_per_evaluation']:.3f} |"
        )
    (OUT / "cost.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
