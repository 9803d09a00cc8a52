"""The bow shock ahead of a circular cylinder: its stand-off distance against the Froude number,
the table of docs/validation.md ("Flow around an obstacle").

    python benchmarks/bow_shock.py [--out benchmarks/bow_shock] [--cases sw coulomb30]
        [--froude 2 3 4 5 6] [--resolutions 10 20] [--upstream RADII] [--threads 2]

A uniform supercritical stream (h0 = 5 mm) meets a solid cylinder of radius R = 25 mm
(`tiseg.post.analysis.bow_shock`); each run goes on until the stand-off distance changes by
less than 2.5e-4 D over 10 R / u0 (at least 40, at most 200 R / u0). Cases:

* ``sw``: no friction on a flat plane, the shallow-water equations, where the stand-off over
  the diameter D depends on F alone;
* ``coulomb30``: a 30 degree slope with Coulomb friction tan(30 deg), so gravity and friction
  balance in the oncoming stream (R / h0 = 5 matters here).

Resolutions are cells per radius. Each finished run is appended to bow_shock.csv at once, and
runs already there (same case, F and resolution) are skipped, so a stopped study resumes;
bow_shock.md is written from the whole csv.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

CASES = {
    "sw": {"friction": "none", "zeta_deg": 0.0},
    "coulomb30": {"friction": "coulomb", "zeta_deg": 30.0},
}
DEFAULT_FROUDE = {"sw": [2.0, 3.0, 4.0, 5.0, 6.0], "coulomb30": [3.0, 4.0, 5.0, 6.0]}
COLUMNS = (
    "case",
    "froude",
    "cells_per_radius",
    "standoff_D",
    "last_change_D",
    "t_end",
    "steady",
    "stagnation",
    "stagnation_exact",
    "upstream",
    "steps",
    "cells",
    "wall_s",
)


def _key(r) -> tuple[str, float, int]:
    return r["case"], float(r["froude"]), int(r["cells_per_radius"])


def _fmt(v) -> str:
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def table(rows, case: str) -> list[str]:
    """Markdown: stand-off / D by F (rows) and resolution (columns), one case; runs that had
    not settled by t_max are marked with a star."""
    mine = [r for r in rows if r["case"] == case]
    if not mine:
        return []
    res = sorted({int(r["cells_per_radius"]) for r in mine})
    frs = sorted({float(r["froude"]) for r in mine})
    by = {_key(r): r for r in mine}
    head = "| F | " + " | ".join(f"{n} cells/R" for n in res) + " | h_s/h0 exact |"
    lines = [head, "|---" * (len(res) + 2) + "|"]
    for f in frs:
        cells = []
        stag = ""
        for n in res:
            r = by.get((case, f, n))
            if r is None:
                cells.append("")
                continue
            mark = "" if r["steady"] == "True" else "*"
            cells.append(f"{float(r['standoff_D']):.3f}{mark} (h_s {float(r['stagnation']):.3f})")
            stag = f"{float(r['stagnation_exact']):.3f}"
        lines.append(f"| {f:g} | " + " | ".join(cells) + f" | {stag} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/bow_shock")
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--froude", nargs="+", type=float, default=None)
    ap.add_argument("--resolutions", nargs="+", type=int, default=[10, 20])
    ap.add_argument("--upstream", type=float, default=None, help="radii ahead of the cylinder")
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args(argv)

    import tiseg
    from tiseg.apps.bench import machine_info, machine_line
    from tiseg.post.analysis.bow_shock import BowShockCase, run_to_steady

    tiseg.init("cpu", "f64", threads=a.threads)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "bow_shock.csv"
    rows = []
    if path.exists():
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
    done = {_key(r) for r in rows}
    for case in a.cases:
        for f in a.froude or DEFAULT_FROUDE[case]:
            for n in a.resolutions:
                if (case, f, n) in done:
                    continue
                c = BowShockCase(f, n, upstream=a.upstream, **CASES[case])
                r = {"case": case, "froude": f, "cells_per_radius": n}
                r.update(run_to_steady(c))
                r["upstream"] = c.face_x / c.radius
                row = {k: _fmt(r[k]) for k in COLUMNS}
                rows.append(row)
                new = not path.exists()
                with open(path, "a", newline="") as fh:
                    w = csv.DictWriter(fh, fieldnames=COLUMNS)
                    if new:
                        w.writeheader()
                    w.writerow(row)
                print(
                    f"{case:10s} F {f:g}  {n:3d} cells/R  stand-off {r['standoff_D']:.4f} D"
                    f"  (change {r['last_change_D']:.1e} at {r['t_end']:g} R/u0)  h_s/h0 "
                    f"{r['stagnation']:.3f} (exact {r['stagnation_exact']:.3f})  "
                    f"{r['steps']} steps  {r['wall_s']:.1f} s",
                    flush=True,
                )
    md = [
        f"# Bow shock stand-off ahead of a cylinder ({machine_line(machine_info(a.threads))})",
        "",
        "Stand-off distance / D on the centreline (the jump where h crosses (h0 + h2) / 2), and",
        "in brackets h / h0 in the cell against the cylinder, to set against the exact stagnation",
        "depth behind a normal jump (Bernoulli from the jump to the face). * = not settled by",
        "t_max (the last change in bow_shock.csv).",
        "",
        "## sw: no friction, flat plane (shallow water)",
        "",
        *table(rows, "sw"),
        "",
        "## coulomb30: 30 degree slope, Coulomb friction tan 30 deg, R / h0 = 5",
        "",
        *table(rows, "coulomb30"),
        "",
        "Wall time of all the runs: "
        f"{sum(float(r['wall_s']) for r in rows):.0f} s ({len(rows)} runs).",
    ]
    (out / "bow_shock.md").write_text("\n".join(md) + "\n")
    print(f"written {path} and {out / 'bow_shock.md'}")
    return 0 if all(math.isfinite(float(r["standoff_D"])) for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
