"""Finger ensembles per numerics option: which option reaches the 750 cells/m values of the
wavelength and the elongation at the lowest cost (issue 12, the work-precision diagram).

    python benchmarks/contacts_fingers.py SWEEP_DIR [SWEEP_DIR ...] --out benchmarks/contacts

Each SWEEP_DIR is the folder of a ``tiseg sweep`` of the fingers scene (e.g. ``grid-study``);
every finished run in it (a folder with ``done.json``) is grouped by its numerics (read from its
own ``scene.toml``: reconstruction, theta, flux, phi_flux) and its resolution. Per group: mean ± sd over the seeds of the finger
wavelength Λ and of the elongation x_l at t = 2.5, 5 and 7.5 s, and the mean work (operator
evaluations x cells) and wall time per run. The reference of each option is its own 750
cells/m ensemble; a point "reaches" it when |mean - mean_750| <= sd_750 for Λ and for x_l at
7.5 s (for Λ at least half the step of Ly/N between N and N + 1 fingers, where the seeds agree
exactly and sd = 0). Writes
``fingers.md`` and ``fingers.png`` (|Λ - Λ_750| and |x_l - x_l,750| against work).
"""

from __future__ import annotations

import argparse
import math
import sys
import tomllib
from collections import defaultdict
from pathlib import Path

import numpy as np

TIMES = ("2.5", "5", "7.5")
REF_RES = 750


def label(num: dict) -> str:
    """The option's name as in tiseg bench accuracy (scheme_label)."""
    from tiseg.apps.bench.accuracy import scheme_label

    base = scheme_label(
        {
            "reconstruction": num.get("reconstruction", "weno"),
            "theta": num.get("theta", 1.5),
            "flux": num.get("flux", "kt"),
            "phi_flux": num.get("phi_flux", "central"),
        }
    )
    # runs from before issue 14 have no step_rule: theirs was "max"
    return base + ("+sum" if num.get("step_rule", "max") == "sum" else "")


def collect(folders) -> dict:
    """{(label, resolution): [row dict, ...]} over the finished runs (folders with done.json)
    of the sweeps, read from each run's own done.json and scene.toml (a sweep that was stopped
    early has no complete sweep.csv)."""
    import json

    groups = defaultdict(list)
    for folder in folders:
        for done in sorted(Path(folder).glob("*/done.json")):
            d = json.loads(done.read_text())
            scene = tomllib.loads((done.parent / "scene.toml").read_text())
            m = d["metrics"]
            times = [float(t) for t in m["time"]]
            row = {
                "finger_count": m["finger_count"][-1],
                "wavelength": m["wavelength"][-1],
                "rhs_evaluations": d["rhs_evaluations"],
                "cells": d["cells"],
                "wall_s": d["wall_s"],
            }
            for t in TIMES:
                k = min(range(len(times)), key=lambda i: abs(times[i] - float(t)))
                row[f"elongation@{t}"] = (
                    m["elongation"][k] if abs(times[k] - float(t)) < 1e-6 else None
                )
            res = round(1.0 / float(d["dx"]))
            groups[(label(scene.get("numerics", {})), res)].append(row)
    return groups


def stats(rows, col) -> tuple[float, float, int]:
    v = np.array([float(r[col]) for r in rows if r.get(col) not in ("", None)])
    if not v.size:
        return math.nan, math.nan, 0
    return float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else 0.0, int(v.size)


def summarise(groups) -> list[dict]:
    out = []
    for (lab, res), rows in sorted(groups.items()):
        d = {"scheme": lab, "resolution": res, "n": len(rows)}
        d["wavelength"] = stats(rows, "wavelength")
        d["count"] = stats(rows, "finger_count")
        for t in TIMES:
            d[f"x_l@{t}"] = stats(rows, f"elongation@{t}")
        d["work"] = float(np.mean([float(r["rhs_evaluations"]) * float(r["cells"]) for r in rows]))
        d["wall"] = float(np.mean([float(r["wall_s"]) for r in rows]))
        out.append(d)
    return out


def reaches(d, ref, key, floor) -> bool:
    m, _, _ = d[key]
    rm, rs, _ = ref[key]
    return abs(m - rm) <= max(rs, floor)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweeps", nargs="+", help="sweep folders (each with sweep.csv)")
    ap.add_argument("--out", default="benchmarks/contacts")
    ap.add_argument(
        "--reference",
        default=None,
        metavar="SCHEME",
        help="the 750 cells/m ensemble that options without one of their own are "
        "measured against (e.g. weno+up)",
    )
    a = ap.parse_args(argv)
    rows = summarise(collect(a.sweeps))
    refs = {d["scheme"]: d for d in rows if d["resolution"] == REF_RES}
    borrowed = set()
    if a.reference in refs:
        for lab in {d["scheme"] for d in rows} - set(refs):
            refs[lab] = refs[a.reference]
            borrowed.add(lab)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)

    def pm(t, fmt, scale=1.0):
        m, s, n = t
        if not n:
            return "–"
        return f"{m * scale:{fmt}} ± {s * scale:{fmt}}" if n > 1 else f"{m * scale:{fmt}}"

    md = [
        "# Finger ensembles per numerics option",
        "",
        "Mean ± sd over the seeds (n per row) at t = 7.5 s unless stated; work = operator "
        "evaluations x cells per run; wall = mean per run (1 thread, 2 runs at a time on the "
        "shared 2-core machine). 'reaches 750' = Λ and x_l(7.5 s) within one sd of the same "
        "option's 750 cells/m ensemble, or within half the step of Λ = Ly/N between N and N + 1 "
        "fingers where the seeds agree exactly (sd 0).",
        "",
        "| scheme | cells/m | n | fingers | Λ [cm] | x_l 2.5 s | x_l 5 s | x_l 7.5 s | "
        "work [1e9] | wall [s] | reaches 750 |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for d in rows:
        ref = refs.get(d["scheme"])
        ok = ""
        if ref is not None and d is not ref and d["resolution"] != REF_RES:
            # half the step of Λ = Ly / N between N and N + 1 fingers at the reference count
            n_ref = max(ref["count"][0], 1.0)
            width = ref["wavelength"][0] * n_ref
            lam_floor = 0.5 * (width / n_ref - width / (n_ref + 1))
            ok = (
                "yes"
                if (reaches(d, ref, "wavelength", lam_floor) and reaches(d, ref, "x_l@7.5", 0.0))
                else "no"
            )
            if d["scheme"] in borrowed:
                ok += f" (vs {a.reference})"
        md.append(
            f"| {d['scheme']} | {d['resolution']} | {d['n']} | {pm(d['count'], '.1f')} | "
            f"{pm(d['wavelength'], '.2f', 100)} | {pm(d['x_l@2.5'], '.3f')} | "
            f"{pm(d['x_l@5'], '.3f')} | {pm(d['x_l@7.5'], '.3f')} | "
            f"{d['work'] / 1e9:.2f} | {d['wall']:.0f} | {ok} |"
        )
    (out / "fingers.md").write_text("\n".join(md) + "\n")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for (key, title, scale, unit), ax in zip(
        (
            ("wavelength", "finger wavelength Λ at 7.5 s", 100, "cm"),
            ("x_l@7.5", "elongation x_l at 7.5 s", 1, "m"),
        ),
        axes,
    ):
        for lab in dict.fromkeys(d["scheme"] for d in rows):
            pts = [d for d in rows if d["scheme"] == lab and d["resolution"] != REF_RES]
            ref = refs.get(lab)
            if ref is None or not pts:
                continue
            x = [d["work"] for d in pts]
            y = [abs(d[key][0] - ref[key][0]) * scale for d in pts]
            e = [d[key][1] * scale for d in pts]
            name = f"{lab} (vs {a.reference} at 750)" if lab in borrowed else lab
            ax.errorbar(x, y, yerr=e, marker="o", capsize=3, label=name)
            for d, xv, yv in zip(pts, x, y):
                ax.annotate(
                    str(d["resolution"]),
                    (xv, yv),
                    fontsize=7,
                    xytext=(3, 3),
                    textcoords="offset points",
                )
            ax.axhline(
                ref[key][1] * scale,
                ls=":",
                lw=0.8,
                color=ax.lines[-1].get_color() if ax.lines else "k",
            )
        ax.set_xscale("log")
        ax.set_xlabel("work per run: operator evaluations x cells")
        ax.set_ylabel(f"|mean - mean at 750 cells/m| [{unit}]")
        ax.set_title(title + " (dotted: sd at 750)", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "fingers.png", dpi=110)
    print("\n".join(md))
    print(f"written {out / 'fingers.md'} and {out / 'fingers.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
