"""Fronts against exact solutions, both schemes, against resolution: the tables of
docs/verification.md ("Fronts").

    python benchmarks/fronts.py [--out benchmarks/fronts] [--quick]

Three problems of the problems library (tiseg/data/problems), each at four resolutions, with
the split MUSCL-Hancock sweeps (the scenes' default) and the unsplit RKC scheme (cfl 0.5):

* ``ritter``: the frictionless dam break onto a dry bed, here 3 mm deep at the default
  h_min = 1e-4 m (h_min / h0 = 1/30), at 0.25 s: the error of the front (the last cell with
  h >= h_min) against the exact h = h_min point, relative to its distance from the dam;
* ``mangeney``: the dam break with Coulomb friction on a slope (Mangeney et al. 2000) at 15 s:
  the relative L1 error of h, the 1 cm front and the rarefaction's tail (99 % of h0) against
  the exact ones [m];
* ``parabolic-cap``: Savage & Hutter's sliding cap at 0.2 s: the relative L1 error of h and
  the errors of its rear and front margins (h = h_min) [cells].

Each row also gives the steps and the wall time of the run (one process, so compare within a
table). Writes fronts.csv and fronts.md into --out.
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import numpy as np

SCHEMES = {"hancock (split, default)": None, "rkc (unsplit)": {"stepper": "rkc", "cfl": 0.5}}


def _x(sim):
    return np.asarray(sim.scene.domain.cell_centres()[0], dtype=float).ravel()


def _crossing(h, x, level, from_right=True):
    """Where h crosses ``level``: downslope of its last cell above it (from_right) or
    upslope of its first cell below it, linearly interpolated."""
    if from_right:
        k = int(np.nonzero(h >= level)[0].max())
        return float(x[k] + (x[k + 1] - x[k]) * (h[k] - level) / (h[k] - h[k + 1]))
    k = int(np.nonzero(h < level)[0].min())
    return float(x[k - 1] + (x[k] - x[k - 1]) * (h[k - 1] - level) / (h[k - 1] - h[k]))


def ritter(nx, numerics):
    from tiseg.run.simulation import Simulation
    from tiseg.setup.scene import load_scene

    over = {"domain.nx": nx, "initial.h_left": 0.003, "initial.x0": 0.1, "time.t_end": 0.25}
    over.update({f"numerics.{k}": v for k, v in (numerics or {}).items()})
    sim = Simulation(load_scene("dam-break", over))
    w = time.perf_counter()
    sim.advance(0.25)
    wall = time.perf_counter() - w
    h, x = sim.fields()["h"][0], _x(sim)
    hmin = sim.scene.numerics.h_min
    front = x[np.nonzero(h >= hmin)[0].max()] + 0.5 * sim.scene.dx
    exact = 0.1 + (2 * math.sqrt(9.81 * 0.003) - 3 * math.sqrt(9.81 * hmin)) * 0.25
    return {
        "front error [% of run-out]": 100 * (front - exact) / (exact - 0.1),
        "steps": sim.stats.steps,
        "wall [s]": wall,
    }


def _problem_run(name, nx, numerics):
    """(scene, simulation, raw record, wall time) of a library problem's timed run."""
    from tiseg.post.problems import load_problem
    from tiseg.run.simulation import Simulation

    p = load_problem(name)
    sc = p.build(nx, numerics)
    sim = Simulation(sc)
    w = time.perf_counter()
    raw = p.run(sim)
    return p, sc, sim, raw, time.perf_counter() - w


def mangeney(nx, numerics):
    from tiseg.model.exact_friction import dam_break_contour

    p, sc, sim, raw, wall = _problem_run("mangeney", nx, numerics)
    h, x = raw["h"], _x(sim)
    zeta, delta = math.radians(22.0), math.atan(sc.effects.coulomb_mu)
    front = _crossing(h, x, 0.01) - dam_break_contour(0.01, 15.0, 1.0, zeta, delta, 60.0)
    tail = _crossing(h, x, 0.99, False) - dam_break_contour(0.99, 15.0, 1.0, zeta, delta, 60.0)
    return {
        "L1(h)": p.score(raw, sc)[1],
        "1 cm front error [m]": front,
        "tail error [m]": tail,
        "steps": sim.stats.steps,
        "wall [s]": wall,
    }


def cap(nx, numerics):
    from tiseg.model.exact_friction import ParabolicCap

    p, sc, sim, raw, wall = _problem_run("parabolic-cap", nx, numerics)
    h, x, dx = raw["h"], _x(sim), sc.dx
    ini = sc.initial
    exact = ParabolicCap(
        ini.x0, ini.half_width, ini.h, ini.u, math.radians(27.0), math.atan(sc.effects.coulomb_mu)
    )
    hmin = sc.numerics.h_min
    a, _ = exact.half_width(sc.t_end)
    xc = sum(exact.margins(sc.t_end)) / 2
    s = math.sqrt(1 - hmin * a / (ini.h * ini.half_width))
    wet = np.nonzero(h >= hmin)[0]
    return {
        "L1(h)": p.score(raw, sc)[1],
        "rear error [cells]": (x[wet.min()] - 0.5 * dx - (xc - s * a)) / dx,
        "front error [cells]": (x[wet.max()] + 0.5 * dx - (xc + s * a)) / dx,
        "steps": sim.stats.steps,
        "wall [s]": wall,
    }


CASES = {
    "ritter": (ritter, [300, 600, 1200, 2400], "cells on 0.3 m"),
    "mangeney": (mangeney, [250, 500, 1000, 2000], "cells on 200 m"),
    "parabolic-cap": (cap, [250, 500, 1000, 2000], "cells on 0.4 m"),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=Path("benchmarks/fronts"))
    ap.add_argument("--quick", action="store_true", help="the two coarsest resolutions only")
    args = ap.parse_args(argv)

    import tiseg

    tiseg.init(arch="cpu", precision="f64")
    rows = []
    for case, (fn, resolutions, label) in CASES.items():
        for scheme, numerics in SCHEMES.items():
            for nx in resolutions[:2] if args.quick else resolutions:
                r = {"problem": case, "scheme": scheme, "resolution": nx, "unit": label}
                r.update(fn(nx, numerics))
                rows.append(r)
                print({k: (round(v, 6) if isinstance(v, float) else v) for k, v in r.items()})
    args.out.mkdir(parents=True, exist_ok=True)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(args.out / "fronts.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, keys)
        w.writeheader()
        w.writerows(rows)
    lines = []
    for case in CASES:
        sub = [r for r in rows if r["problem"] == case]
        cols = [k for k in keys if k not in ("problem", "unit") and any(k in r for r in sub)]
        lines += [f"### {case} ({sub[0]['unit']})", ""]
        lines += ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
        for r in sub:
            cells = [f"{r[k]:.3g}" if isinstance(r[k], float) else str(r[k]) for k in cols]
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
    (args.out / "fronts.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
