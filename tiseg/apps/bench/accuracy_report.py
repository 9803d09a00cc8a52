"""What the accuracy study reports: relative errors against the reference runs, the Pareto
front per problem, whether the scene defaults sit on it, and the files (accuracy.csv, one PNG
per problem, summary.md)."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Sequence

import numpy as np

from . import machine_line
from .accuracy_points import DEFAULT_COMBO, LEGACY_SCHEME, PROBLEMS, scheme_label

COLUMNS = (
    "problem",
    "resolution",
    "reconstruction",
    "stepper",
    "precision",
    "backend",
    "error",
    "wall_s",
    "steps",
    "rhs_evals",
    "cells",
    "cfl",
    "value",
    "status",
    "pareto",
    "theta",
    "flux",
    "phi_flux",
)  # (the scheme's last three came later: appended)


def pareto_front(errors: Sequence[float], walls: Sequence[float]) -> list[int]:
    """Indices of the non-dominated points (minimise both error and wall time), by wall time.

    A point is dominated when another is no worse in both and better in one. Points with a
    non-finite error or time are never on the front."""
    idx = [i for i in range(len(errors)) if math.isfinite(errors[i]) and math.isfinite(walls[i])]
    # cheapest first; at equal time the more accurate first, so that it dominates the other
    idx.sort(key=lambda i: (walls[i], errors[i]))
    front, best = [], math.inf
    for i in idx:
        if errors[i] < best:
            front.append(i)
            best = errors[i]
    return front


def _is_default(row: dict) -> bool:
    # rows from before the flux options have no flux / phi_flux: they ran the legacy scheme
    return all(row.get(k, LEGACY_SCHEME.get(k)) == v for k, v in DEFAULT_COMBO.items())


def _work(row: dict) -> int:
    """Cell-updates of a run: operator evaluations x cells."""
    return int(row["rhs_evals"]) * int(row["cells"])


FRONT_KEYS = ("resolution", "reconstruction", "stepper", "precision", "backend", "error", "wall_s")
WORK_KEYS = ("resolution", "reconstruction", "stepper", "precision", "error", "rhs_evals")


def _described(row: dict, keys) -> dict:
    """A point as the assessment names it: its scheme label and the given columns."""
    return {"scheme": scheme_label(row), **{k: row[k] for k in keys}}


def assess_defaults(rows: Sequence[dict]) -> dict:
    """Per problem: for each default point (weno + rkc + f64 + cpu, cfl 0.25), is it on the
    Pareto front, and if not, how much faster the front reaches the same error.

    ``overhead`` = wall of the default / wall of the cheapest front point with an error no
    larger (1 on the front); ``instead`` names that point."""
    out = {}
    for prob in dict.fromkeys(r["problem"] for r in rows):
        pts = [r for r in rows if r["problem"] == prob and r["status"] == "ok"]
        front = [r for r in pts if r.get("pareto")]
        items = []
        for r in sorted((r for r in pts if _is_default(r)), key=lambda r: r["resolution"]):
            better = [f for f in front if f["error"] <= r["error"]]
            best = min(better, key=lambda f: f["wall_s"]) if better else r
            # the same question in cell-updates (operator evaluations x cells): a cost that
            # does not depend on the machine's load, nor on per-step overheads or precision
            cheaper = [q for q in pts if q["error"] <= r["error"]]
            least = min(cheaper, key=_work)
            items.append(
                {
                    "resolution": r["resolution"],
                    "error": r["error"],
                    "wall_s": r["wall_s"],
                    "on_front": bool(r.get("pareto")),
                    "overhead": r["wall_s"] / best["wall_s"] if best["wall_s"] > 0 else 1.0,
                    "instead": _described(best, FRONT_KEYS),
                    "work": _work(r),
                    "work_overhead": _work(r) / max(_work(least), 1),
                    "work_instead": _described(least, WORK_KEYS),
                }
            )
        ov = [i["overhead"] for i in items]
        wo = [i["work_overhead"] for i in items]
        out[prob] = {
            "defaults": items,
            "median_work_overhead": float(np.median(wo)) if wo else float("nan"),
            "on_front": sum(i["on_front"] for i in items),
            "count": len(items),
            "median_overhead": float(np.median(ov)) if ov else float("nan"),
            "max_overhead": float(max(ov)) if ov else float("nan"),
            "front": [_described(f, FRONT_KEYS) for f in sorted(front, key=lambda f: f["wall_s"])],
        }
    return out


def verdict(assessment: dict, clear: float = 1.5) -> str:
    """One paragraph: do the defaults sit on the front? 'Clearly not' = the front reaches the
    default's error at least ``clear`` times faster at the median default point."""
    lines = []
    for prob, a in assessment.items():
        if not a["count"]:
            continue
        worst = max(a["defaults"], key=lambda i: i["overhead"])
        ins = worst["instead"]
        tag = (
            "on the front"
            if a["on_front"] == a["count"]
            else "near the front"
            if a["median_overhead"] < clear
            else "clearly NOT on the front"
        )
        lines.append(
            f"- {prob}: {a['on_front']}/{a['count']} default points on the front, median "
            f"overhead {a['median_overhead']:.2f}x in wall time and "
            f"{a['median_work_overhead']:.2f}x in cell-updates ({tag}); worst at resolution "
            f"{worst['resolution']}: {worst['wall_s']:.3g} s for error {worst['error']:.3g}, "
            f"where {ins['scheme']} + {ins['stepper']} + {ins['precision']} at "
            f"resolution {ins['resolution']} gets {ins['error']:.3g} in {ins['wall_s']:.3g} s"
        )
    return "\n".join(lines)


def _fill_relative_errors(rows: list[dict]) -> None:
    """Errors of problems scored against their finest run (the row flagged reference)."""
    for name, prob in PROBLEMS.items():
        if not prob.reference_resolution:
            continue
        refs = [
            r
            for r in rows
            if r["problem"] == name and r["status"] == "reference" and math.isfinite(r["value"])
        ]
        if not refs:
            continue
        ref = refs[0]["value"]
        for r in rows:
            if r["problem"] == name and r["status"] == "ok":
                r["error"] = (
                    abs(r["value"] - ref) / abs(ref) if math.isfinite(r["value"]) else math.nan
                )
                if not math.isfinite(r["error"]):
                    r["status"] = "unstable"


def mark_pareto(rows: list[dict]) -> None:
    """Set ``pareto`` on every row (per problem, over the successful points)."""
    for r in rows:
        r["pareto"] = False
    for prob in dict.fromkeys(r["problem"] for r in rows):
        pts = [r for r in rows if r["problem"] == prob and r["status"] == "ok"]
        for i in pareto_front([r["error"] for r in pts], [r["wall_s"] for r in pts]):
            pts[i]["pareto"] = True


def write_csv(rows: Sequence[dict], path: Path) -> Path:
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: _fmt(r.get(k)) for k in COLUMNS})
    return path


def read_csv(path) -> list[dict]:
    """Rows of an accuracy.csv with numbers parsed back."""
    rows = []
    with open(path, newline="") as fh:
        for r in csv.DictReader(fh):
            for k in ("error", "wall_s", "cfl", "value"):
                r[k] = float(r[k]) if r[k] not in ("", None) else math.nan
            # files written before the flux options had none of these columns
            r["theta"] = float(r.get("theta") or LEGACY_SCHEME["theta"])
            r["flux"] = r.get("flux") or LEGACY_SCHEME["flux"]
            r["phi_flux"] = r.get("phi_flux") or LEGACY_SCHEME["phi_flux"]
            for k in ("resolution", "steps", "rhs_evals", "cells"):
                r[k] = int(r[k])
            r["pareto"] = r["pareto"] == "True"
            rows.append(r)
    return rows


def _fmt(v):
    if isinstance(v, float):
        return "" if not math.isfinite(v) else f"{v:.6g}"
    return v


def plot_problem(rows: Sequence[dict], problem: str, path: Path, machine: str = "") -> Path:
    """Error against wall time for one problem; the Pareto front as a black staircase."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    prob = PROBLEMS[problem]
    pts = [
        r
        for r in rows
        if r["problem"] == problem and r["status"] == "ok" and r["error"] > 0 and r["wall_s"] > 0
    ]
    colours = {"first-order": "tab:gray", "minmod1.5": "tab:blue", "weno": "tab:red"}
    extra = iter(
        (
            "tab:green",
            "tab:purple",
            "tab:orange",
            "tab:brown",
            "tab:pink",
            "tab:olive",
            "tab:cyan",
            "navy",
            "darkred",
            "teal",
            "gold",
            "k",
        )
    )
    for lab in dict.fromkeys(scheme_label(r) for r in pts):
        if lab not in colours:
            colours[lab] = next(extra, "k")
    markers = {"rkc": "o", "ssprk3": "s", "euler": "^", "ssprk2": "D"}
    fig, ax = plt.subplots(figsize=(8, 6))
    for r in pts:
        c = colours.get(scheme_label(r), "k")
        filled = r["precision"] == "f64"
        ax.scatter(
            r["wall_s"],
            r["error"],
            marker=markers.get(r["stepper"], "x"),
            s=60 if r["backend"] == "cpu" else 110,
            facecolors=c if filled else "none",
            edgecolors=c,
            linewidths=1.3,
            zorder=3,
        )
        ax.annotate(
            str(r["resolution"]),
            (r["wall_s"], r["error"]),
            fontsize=6,
            xytext=(3, 3),
            textcoords="offset points",
            color=c,
        )
    front = sorted((r for r in pts if r.get("pareto")), key=lambda r: r["wall_s"])
    if front:
        xs = [f["wall_s"] for f in front]
        ys = [f["error"] for f in front]
        ax.step(xs + [xs[-1] * 3], ys + [ys[-1]], where="post", color="k", lw=1.2, zorder=2)
        ax.scatter(xs, ys, s=200, facecolors="none", edgecolors="k", linewidths=1.0, zorder=4)
    defaults = sorted((r for r in pts if _is_default(r)), key=lambda r: r["wall_s"])
    if defaults:
        ax.plot(
            [d["wall_s"] for d in defaults],
            [d["error"] for d in defaults],
            "--",
            color="tab:red",
            lw=1,
            zorder=1,
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time of the run [s]")
    ax.set_ylabel(prob.error_label)
    ax.set_title(f"{prob.title}\n(labels: {prob.resolution_label}; {machine})", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    used = {scheme_label(r) for r in pts}
    handles = (
        [
            Line2D([], [], ls="", marker="o", color=c, label=k)
            for k, c in colours.items()
            if k in used
        ]
        + [
            Line2D([], [], ls="", marker=m, color="0.55", label=k)
            for k, m in markers.items()
            if any(r["stepper"] == k for r in pts)
        ]
        + [
            Line2D([], [], ls="", marker="o", color="k", label="f64 (filled)"),
            Line2D([], [], ls="", marker="o", color="k", mfc="none", label="f32 (open)"),
            Line2D([], [], color="k", label="Pareto front (circled)"),
            Line2D([], [], color="tab:red", ls="--", label="scene default weno+rkc+f64"),
        ]
    )
    ax.legend(handles=handles, fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def summary_markdown(rows: Sequence[dict], assessment: dict, machine: dict) -> str:
    """The study in short: per problem the Pareto front and where the defaults sit."""
    out = [f"# Accuracy against cost ({machine_line(machine)})", ""]
    ok = sum(r["status"] == "ok" for r in rows)
    bad = [r for r in rows if r["status"] == "unstable"]
    which = ", ".join(sorted({r["problem"] + "/" + r["stepper"] for r in bad})) or "none"
    out.append(f"{len(rows)} runs, {ok} scored, {len(bad)} unstable ({which}).")
    out += [
        "",
        "## Do the defaults (weno + rkc + f64, cfl 0.25) sit on the Pareto front?",
        "",
        verdict(assessment),
        "",
    ]
    for prob, a in assessment.items():
        p = PROBLEMS[prob]
        out += [
            f"## {prob}: {p.title}",
            "",
            f"error: {p.error_label}; resolution: {p.resolution_label}",
            "",
            "| front point | resolution | error | wall [s] |",
            "|---|---|---|---|",
        ]
        for f in a["front"]:
            out.append(
                f"| {f['scheme']} + {f['stepper']} + {f['precision']}/{f['backend']} "
                f"| {f['resolution']} | {f['error']:.3g} | {f['wall_s']:.3g} |"
            )
        out += [
            "",
            "| default at resolution | error | wall [s] | on front | overhead | "
            "cheapest front point with no larger error | cell-updates overhead | "
            "fewest cell-updates with no larger error |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for d in a["defaults"]:
            i, w = d["instead"], d["work_instead"]
            out.append(
                f"| {d['resolution']} | {d['error']:.3g} | {d['wall_s']:.3g} | "
                f"{'yes' if d['on_front'] else 'no'} | {d['overhead']:.2f}x | "
                f"{i['scheme']} + {i['stepper']} + {i['precision']} at "
                f"{i['resolution']}: {i['error']:.3g} in {i['wall_s']:.3g} s | "
                f"{d['work_overhead']:.2f}x | {w['scheme']} + {w['stepper']} at "
                f"{w['resolution']}: {w['error']:.3g} with {w['rhs_evals']} evaluations |"
            )
        out.append("")
    return "\n".join(out)
