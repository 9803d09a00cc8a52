"""The fingers on the split sweeps against the unsplit scheme: ensembles side by side.

Each ensemble is a ``tiseg sweep grid-study`` folder (or a copy of its ``sweep.csv``) with the
numerics it was run with given as a label, e.g.

    tiseg sweep grid-study --out runs/ens/rkc --set 'numerics.stepper="rkc"' \
        --set 'numerics.step_rule="sum"' --set numerics.cfl=0.5 \
        --grid 'domain.resolution=[250,375,500,750]' --grid 'inflow.seed=[1,2,3,4,5]'
    tiseg sweep grid-study --out runs/ens/hancock --grid 'domain.resolution=[250,375,500,750]' \
        --grid 'inflow.seed=[1,2,3,4,5]'
    python benchmarks/split_fingers.py --reference rkc rkc=runs/ens/rkc hancock=runs/ens/hancock

(the sweep tables of the published numbers are in benchmarks/split_fingers/ensembles/).

The reference is the ``--reference`` label's ensemble at the finest resolution (750 cells/m).
Every other (label, resolution) ensemble is compared with it metric by metric: the difference
of the means with its 95 % Welch interval, widened by what the measurement cannot resolve: half
the step of Λ = Ly/N between N and N + 1 fingers at the reference's mean count (Λ is a count),
and one cell of the coarser grid (x_l, a distance between front positions on the grid). The
spectral Λ is not widened. An ensemble *reaches* the reference when the widened interval of
every metric in AGREE (Λ, spectral Λ, x_l at 2.5, 5 and 7.5 s) holds 0.

Writes ``split_fingers.md`` (the tables), ``split_fingers.csv`` (mean, sd, n per label,
resolution and metric) and ``split_fingers.png`` (work-precision: the mean wall time per run
against |mean - reference mean| of Λ and of x_l at 7.5 s, with the reference's 95 % interval
half-width as a band) into ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import math
from collections import defaultdict
from pathlib import Path

from ensemble_stats import FINGER_METRICS, summary, sweep_rows, welch
from scipy import stats

# (column of sweep.csv, label, scale for display)
METRICS = [
    *FINGER_METRICS,
    ("steps", "steps", 1.0),
    ("rhs_evaluations", "evaluations (sweeps + viscous stages)", 1.0),
    ("wall_s", "wall per run [s]", 1.0),
]
# the metrics that decide whether an ensemble reaches the reference (issue 34, part 3)
AGREE = (
    "wavelength@7.5",
    "wavelength_spectral@7.5",
    "elongation@2.5",
    "elongation@5",
    "elongation@7.5",
)
LY = 0.5  # the fingers scene's width [m]


def values(rows, res: int, key: str) -> list[float]:
    out = []
    for r in rows:
        if int(float(r["domain.resolution"])) == res and r.get(key) not in (None, "", "nan"):
            out.append(float(r[key]))
    return out


def ci_half(sd: float, n: int) -> float:
    """Half-width of the 95 % interval of a mean of n draws."""
    return stats.t.ppf(0.975, n - 1) * sd / math.sqrt(n) if n > 1 else math.nan


def quantum(key: str, ref_count: float, res: int, ref_res: int) -> float:
    """What the measurement cannot resolve: half the step of Λ between N and N + 1 fingers
    (Λ) and one cell of the coarser grid (x_l)."""
    if key == "wavelength@7.5":
        n = max(ref_count, 1.0)
        return 0.5 * (LY / n - LY / (n + 1))
    if key.startswith("elongation"):
        return 1.0 / min(res, ref_res)
    return 0.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ensembles", nargs="+", metavar="LABEL=SWEEP", help="label=sweep folder")
    ap.add_argument(
        "--reference", required=True, help="the label whose finest ensemble is the reference"
    )
    ap.add_argument("--out", default="benchmarks/split_fingers")
    a = ap.parse_args(argv)

    data: dict[str, list[dict]] = defaultdict(list)
    for item in a.ensembles:
        label, _, path = item.partition("=")
        data[label] += sweep_rows(Path(path))
    groups = sorted(
        {(lab, int(float(r["domain.resolution"]))) for lab, rs in data.items() for r in rs},
        key=lambda g: (g[1], g[0]),
    )
    ref_res = max(res for lab, res in groups if lab == a.reference)
    ref = data[a.reference]
    ref_count = summary(values(ref, ref_res, "finger_count@7.5"))[0]

    table, md = [], []
    md.append(f"Reference: {a.reference} at {ref_res} cells/m.\n")
    md.append(
        "| numerics | cells/m | n | "
        + " | ".join(lab for _, lab, _ in METRICS)
        + " | reaches the reference |"
    )
    md.append("|---|---|---|" + "---|" * (len(METRICS) + 1))
    deltas = []
    for lab, res in groups:
        cells, ok = [], True
        n = 0
        for key, _, scale in METRICS:
            v = values(data[lab], res, key)
            if not v:
                cells.append("–")
                continue
            m, sd, n = summary(v)
            table.append([lab, res, key, n, m, sd])
            cells.append(f"{m * scale:.4g} ± {sd * scale:.2g}" if n > 1 else f"{m * scale:.4g}")
            if key in AGREE and not (lab == a.reference and res == ref_res):
                d, hw = welch(v, values(ref, ref_res, key))
                q = quantum(key, ref_count, res, ref_res)
                hit = abs(d) <= hw + q
                ok &= hit
                deltas.append((lab, res, key, d, hw, q, hit))
        verdict = (
            "(reference)" if (lab == a.reference and res == ref_res) else ("yes" if ok else "no")
        )
        md.append(f"| {lab} | {res} | {n} | " + " | ".join(cells) + f" | {verdict} |")

    md.append(
        "\nDifferences from the reference (ensemble − reference), 95 % Welch half-width, "
        "and the measurement quantum added to it:\n"
    )
    md.append("| numerics | cells/m | metric | Δ | ± Welch | + quantum | holds 0 |")
    md.append("|---|---|---|---|---|---|---|")
    for lab, res, key, d, hw, q, hit in deltas:
        scale = dict((k, s) for k, _, s in METRICS)[key]
        md.append(
            f"| {lab} | {res} | {key} | {d * scale:+.3g} | {hw * scale:.3g} | {q * scale:.3g} | "
            f"{'yes' if hit else 'no'} |"
        )

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "split_fingers.md").write_text("\n".join(md) + "\n")
    with open(out / "split_fingers.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["numerics", "resolution", "metric", "n", "mean", "sd"])
        w.writerows(table)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, (key, title, scale, unit) in zip(
        axes,
        (
            ("wavelength@7.5", "Λ at 7.5 s", 100.0, "cm"),
            ("elongation@7.5", "x_l at 7.5 s", 1.0, "m"),
        ),
    ):
        rm, rs, rn = summary(values(ref, ref_res, key))
        ax.axhspan(0, ci_half(rs, rn) * scale, color="0.9", label="reference's 95 % interval")
        for lab in data:
            pts = [
                res
                for l2, res in groups
                if l2 == lab and not (lab == a.reference and res == ref_res)
            ]
            x, y, e = [], [], []
            for res in pts:
                m, sd, n = summary(values(data[lab], res, key))
                x.append(summary(values(data[lab], res, "wall_s"))[0])
                y.append(abs(m - rm) * scale)
                e.append(ci_half(sd, n) * scale)
            if not x:
                continue
            ax.errorbar(x, y, yerr=e, marker="o", capsize=3, label=lab)
            for res, xv, yv in zip(pts, x, y):
                ax.annotate(
                    str(res), (xv, yv), fontsize=7, xytext=(3, 3), textcoords="offset points"
                )
        ax.set_xscale("log")
        ax.set_xlabel("wall per run [s] (1 thread)")
        ax.set_ylabel(f"|mean − reference| [{unit}]")
        ax.set_title(title)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "split_fingers.png", dpi=120)
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
