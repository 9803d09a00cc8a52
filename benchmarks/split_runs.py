"""Whole runs side by side: the split sweeps against the unsplit default, and thread counts.

    python benchmarks/split_runs.py --out benchmarks/split_threads --cases dambreak fingers500 \
        --threads 1 2 --repeats 3                       # threads (issue 34, part 4)
    python benchmarks/split_runs.py --out benchmarks/split_paper --cases fingers375-rkc \
        fingers375-hancock fingers750-rkc fingers750-hancock --threads 2 --repeats 1

Each case is a whole ``tiseg run`` in a fresh process, the thread counts (and the cases)
alternating within each repeat, so slow drifts of a shared machine's load fall on all of them alike. Reported per
case and thread count: the wall time of the simulation (``wall_time_s`` of ``tiseg run
--json``), the steps, the run's cell-updates per second (cells of the active range times sweeps
and viscous stages, per second) and the speed-up over one thread, with the 1-minute load
average before each run. Writes ``split_runs.md`` and ``split_runs.csv`` into ``--out``.

Cases:

* ``dambreak``: the dam-break scene (split sweeps) on 1024 x 1024 cells (Lx = Ly = 0.3 m), a
  wet bed (h_right = h_left / 4, so every cell is active from the start), t_end = 0.2 s;
* ``fingers500``: the fingers scene at 500 cells/m (750 x 250 cells) on the split sweeps with
  the viscous sub-step (the scene's cfl), to t = 7.5 s;
* ``fingersR-rkc``, ``fingersR-hancock`` (R = 375, 750): the fingers scene at R cells/m to
  7.5 s with the unsplit KT + RKC scheme at the sum rule and its bound, cfl 0.5 (the scene's
  numerics before issue 34) and with the split sweeps at the max rule, cfl 0.6;
  ``fingersR-hancock-cfl0.9``: the split sweeps at cfl 0.9 per sweep (the scene's default).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

CASES = {
    "dambreak": [
        "dam-break",
        "--set", "domain.nx=1024",
        "--set", "domain.ny=1024",
        "--set", "domain.Ly=0.3",
        "--set", "initial.h_right=0.0005",
        "--set", "output.interval=0.1",
    ],
    "fingers500": [
        "fingers",
        "--set", "domain.resolution=500",
        "--set", 'numerics.stepper="hancock"',
        "--set", 'numerics.step_rule="max"',
        "--set", "output.interval=0.5",
    ],
}  # fmt: skip
for _res in (375, 750):
    _base = ["fingers", "--set", f"domain.resolution={_res}", "--set", "output.interval=0.5"]
    CASES[f"fingers{_res}-rkc"] = [
        *_base,
        "--set",
        'numerics.stepper="rkc"',
        "--set",
        'numerics.step_rule="sum"',
        "--set",
        "numerics.cfl=0.5",
    ]
    _split = [*_base, "--set", 'numerics.stepper="hancock"', "--set", 'numerics.step_rule="max"']
    CASES[f"fingers{_res}-hancock"] = [*_split, "--set", "numerics.cfl=0.6"]
    CASES[f"fingers{_res}-hancock-cfl0.9"] = [*_split, "--set", "numerics.cfl=0.9"]


def run_once(case: str, threads: int, folder: Path) -> dict:
    # the tiseg command of this interpreter's environment
    exe = Path(sys.executable).with_name("tiseg")
    cmd = [str(exe) if exe.exists() else "tiseg", "run", *CASES[case], "--threads", str(threads)]
    cmd += ["--out", str(folder), "--overwrite", "--json", "-q"]
    load = os.getloadavg()[0]
    p = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if p.returncode != 0:
        raise SystemExit(f"{case}, {threads} threads failed:\n{p.stderr}")
    s = json.loads(p.stdout)
    return {
        "case": case,
        "threads": threads,
        "wall_s": s["wall_time_s"],
        "steps": s["steps"],
        "evaluations": s["rhs_evaluations"],
        "mass_balance_error": s["mass_balance_error"],
        "cell_updates_per_s": s["cell_updates_per_s"],
        "load_1min": load,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--threads", nargs="+", type=int, default=[1, 2])
    a = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(a.repeats):
            for case in a.cases:
                order = a.threads if rep % 2 == 0 else a.threads[::-1]
                for n in order:
                    r = run_once(case, n, Path(tmp) / f"{case}-{n}")
                    r["repeat"] = rep
                    rows.append(r)
                    print(
                        f"{case} threads={n} wall={r['wall_s']:.2f} s steps={r['steps']} "
                        f"{r['cell_updates_per_s'] / 1e6:.1f} M cell-updates/s "
                        f"load={r['load_1min']:.2f}",
                        file=sys.stderr,
                    )
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "split_runs.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    md = [
        "| case | threads | wall per run [s] (repeats) | steps | sweeps + stages | "
        "M cell-updates/s (best) | speed-up over the first thread count (best / best) | "
        "mass balance error | load (1 min) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for case in a.cases:
        best1 = min(r["wall_s"] for r in rows if r["case"] == case and r["threads"] == a.threads[0])
        for n in a.threads:
            rs = [r for r in rows if r["case"] == case and r["threads"] == n]
            walls = ", ".join(f"{r['wall_s']:.1f}" for r in rs)
            best = min(r["wall_s"] for r in rs)
            cups = max(r["cell_updates_per_s"] for r in rs) / 1e6
            loads = ", ".join(f"{r['load_1min']:.1f}" for r in rs)
            md.append(
                f"| {case} | {n} | {walls} | {rs[0]['steps']} | {rs[0]['evaluations']} | "
                f"{cups:.1f} | {best1 / best:.2f} | {rs[0]['mass_balance_error']:.1e} | {loads} |"
            )
    (out / "split_runs.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
