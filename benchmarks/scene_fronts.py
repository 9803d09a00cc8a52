"""The built-in scenes with dry fronts under both schemes: where the front is at t_end, what it
costs, against a fine reference: the table of docs/verification.md ("Fronts in the scenes").

    python benchmarks/scene_fronts.py [--out benchmarks/scene_fronts] [--scenes ...]

For each scene whose flow advances onto a dry bed (the others have no dry front), each scheme
at 100 and 200 cells/m and the unsplit RKC at 400:

* ``rkc``: the unsplit KT + RKC scheme with step_rule "sum" at its cfl 0.5 (these scenes'
  numerics before monodisperse-front and finite-release moved to the split sweeps);
* ``split``: the fingers scene's numerics (split MUSCL-Hancock sweeps, step_rule "max",
  cfl 0.9 per sweep).

The reference is the split scheme at 400 cells/m: on the exact fronts of benchmarks/fronts.py
(Ritter, Mangeney, the parabolic cap) it converges to the exact front, where RKC's lags by
about 30 % at the h_min cut-off. The front is where the thickness, along the row that reaches
farthest, falls through ``LEVEL`` (interpolated); its error is in cells of the run's own grid
and in mm; it is measured at t_end (the finite releases at 2 s, before the front breaks into
fingers). Rows are appended to scene_fronts.csv as they finish (a killed study resumes).
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

SCENES = ("monodisperse-front", "levees", "finite-release", "finite-release-deposit")
SCHEMES = {
    "rkc": {"numerics.stepper": "rkc", "numerics.step_rule": "sum"},
    "split": {"numerics.stepper": "hancock", "numerics.step_rule": "max", "numerics.cfl": 0.9},
}
RUNS = [("split", 400), ("rkc", 100), ("rkc", 200), ("rkc", 400), ("split", 100), ("split", 200)]
# when the front is measured: t_end, but for the finite releases at 2 s, before their fronts
# break into fingers (about 2.5 s; the tip of a finger is one draw of a chaotic flow) and
# long before they leave the domain
AT = {"finite-release": 2.0, "finite-release-deposit": 2.0}
LEVEL = 5e-4  # [m] the front's thickness: a quarter of h0 = 2 mm, well above h_min = 0.1 mm
FIELDS = ["scene", "scheme", "resolution", "t", "steps", "wall_s", "front_m", "mass_rel", "cells"]


def front(h: np.ndarray, x: np.ndarray, level: float = LEVEL) -> float:
    """The largest x where a row's h falls through ``level`` (h is (ny, nx))."""
    best = -np.inf
    for row in np.atleast_2d(h):
        wet = np.nonzero(row >= level)[0]
        if wet.size == 0:
            continue
        k = int(wet.max())
        if k + 1 >= row.size:
            return float(x[-1])
        best = max(best, float(x[k] + (x[k + 1] - x[k]) * (row[k] - level) / (row[k] - row[k + 1])))
    return best


def run_one(scene: str, scheme: str, resolution: int) -> dict:
    from tiseg.run.simulation import Simulation
    from tiseg.setup.scene import load_scene

    over = {"domain.resolution": resolution, "output.times": [], **SCHEMES[scheme]}
    sim = Simulation(load_scene(scene, over))
    sim.step()  # compiles the kernels: the wall time below is the run's, not the compiler's
    sim.reset()
    w = time.perf_counter()
    sim.advance(AT.get(scene, sim.scene.time.t_end))
    wall = time.perf_counter() - w
    h = sim.fields()["h"]
    x = np.asarray(sim.scene.domain.cell_centres()[0], dtype=float).ravel()
    tot, bud = sim.totals(), sim.budget()
    mass0 = sim.initial_totals["mass"]
    mass_rel = (tot["mass"] - mass0 - bud["mass_in"]) / max(tot["mass"], 1e-300)
    return {
        "scene": scene,
        "scheme": scheme,
        "resolution": resolution,
        "t": sim.t,
        "steps": sim.stats.steps,
        "wall_s": round(wall, 2),
        "front_m": front(h, x),
        "mass_rel": f"{mass_rel:.2e}",
        "cells": h.size,
    }


def table(rows: list[dict]) -> str:
    """Markdown: per scene, each run's front against the split 400 reference."""
    out = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        mine = [r for r in rows if r["scene"] == scene]
        ref = next(
            (r for r in mine if r["scheme"] == "split" and int(r["resolution"]) == 400), None
        )
        if ref is None:
            continue
        xf = float(ref["front_m"])
        out += [
            f"### {scene} at {float(ref['t']):g} s (reference: split at 400 cells/m, front at "
            f"{xf:.4f} m)",
            "",
            "| scheme | cells/m | steps | wall [s] | front [m] | error [mm] | error [cells] |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in mine:
            res = int(r["resolution"])
            err = float(r["front_m"]) - xf
            out.append(
                f"| {r['scheme']} | {res} | {r['steps']} | {float(r['wall_s']):.1f} | "
                f"{float(r['front_m']):.4f} | {1e3 * err:+.1f} | {err * res:+.1f} |"
            )
        out.append("")
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "scene_fronts")
    ap.add_argument("--scenes", nargs="+", default=list(SCENES))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "scene_fronts.csv"
    rows = list(csv.DictReader(path.open())) if path.exists() else []
    done = {(r["scene"], r["scheme"], int(r["resolution"])) for r in rows}
    for scene in args.scenes:
        for scheme, res in RUNS:
            if (scene, scheme, res) in done:
                continue
            row = run_one(scene, scheme, res)
            print(row, flush=True)
            rows.append(row)
            new = not path.exists()
            with path.open("a", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=FIELDS)
                if new:
                    w.writeheader()
                w.writerow(row)
    (args.out / "scene_fronts.md").write_text(table(rows))
    print(table(rows))


if __name__ == "__main__":
    main()
