"""Projected against regularised friction on the fingers scene: ensembles side by side.

Both ensembles are built-in grid-study sweeps with only numerics.friction_scheme changed, e.g.

    tiseg sweep grid-study --out runs/ens/projected --grid 'domain.resolution=[250,375]' \
        --grid 'inflow.seed=[1,2,3,4,5]' --set 'numerics.friction_scheme="projected"'
    (the same with "regularised" into runs/ens/regularised)
    python benchmarks/friction_default.py runs/ens/projected runs/ens/regularised

(the two sweep tables of the published numbers are in benchmarks/friction/ensembles/).

Writes benchmarks/friction/default.csv (one row per scheme, resolution and metric) and
benchmarks/friction/default.md: mean, sd and n per scheme, and the difference of the means with
its 95 % Welch interval. A difference whose interval holds 0 is not resolved by n seeds.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

from ensemble_stats import FINGER_METRICS, summary, sweep_rows, welch

METRICS = [
    *FINGER_METRICS,
    ("rhs_evaluations", "operator evaluations", 1.0),
    ("steps", "steps", 1.0),
]
HERE = Path(__file__).resolve().parent / "friction"


def _values(rows, res, key, scale):
    out = []
    for r in rows:
        if r["domain.resolution"] == res and r.get(key) not in (None, "", "nan"):
            out.append(float(r[key]) * scale)
    return out


def main(projected: str, regularised: str) -> None:
    p, r = sweep_rows(Path(projected)), sweep_rows(Path(regularised))
    resolutions = sorted({x["domain.resolution"] for x in p}, key=float)
    table, lines = [], []
    lines.append("# Projected against regularised friction: fingers ensembles\n")
    lines.append(
        "The grid-study sweep (fingers scene, Ly = 0.5 m, ν = 0.01, inflow noise 1e-4) with "
        "only `numerics.friction_scheme` changed, seeds 1–5 at each resolution, each run on "
        "one thread, two runs at a time (the two sweeps ran one after the other on a "
        "shared machine, so their wall times are not compared: the evaluation counts are the "
        "work). Mean ± sd (n); Δ = projected − regularised with its "
        "95 % Welch interval: an interval that holds 0 means the difference is not resolved "
        "by these seeds. Written by `benchmarks/friction_default.py`.\n"
    )
    for res in resolutions:
        lines.append(f"\n## {res} cells/m\n")
        lines.append("| metric | projected | regularised | Δ (95 % interval) |")
        lines.append("|---|---|---|---|")
        for key, label, scale in METRICS:
            a, b = _values(p, res, key, scale), _values(r, res, key, scale)
            if len(a) < 2 or len(b) < 2:
                continue
            (ma, sa, na), (mb, sb, nb) = summary(a), summary(b)
            d, hw = welch(a, b)
            lo, hi = d - hw, d + hw
            lines.append(
                f"| {label} | {ma:.4g} ± {sa:.2g} ({na}) | {mb:.4g} ± {sb:.2g} ({nb}) | "
                f"{d:+.3g} ({lo:+.3g}, {hi:+.3g}) |"
            )
            for scheme, (m, s, n) in (("projected", (ma, sa, na)), ("regularised", (mb, sb, nb))):
                table.append([res, key, scheme, n, m, s])
    HERE.mkdir(exist_ok=True)
    with open(HERE / "default.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["resolution", "metric", "scheme", "n", "mean", "sd"])
        w.writerows(table)
    (HERE / "default.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
