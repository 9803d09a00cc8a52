"""The channel test for each contact-keeping option: phi at the channel centre and u(y) against
the steady cross-slope solution, at t = 3 s, over a resolution ladder.

    python benchmarks/contacts.py --out benchmarks/contacts [--resolutions 250 500 ...]

One run per (scheme, resolution) on one thread (the channel is x-independent and tiny: 4 to 16
cells downslope); writes contacts.csv (appending, so an interrupted study resumes) and
contacts.md. The scene is the built-in ``channel`` (docs/numerics.md).
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import numpy as np

# (label, numerics overrides); labels as in tiseg bench accuracy (scheme_label)
SCHEMES = {
    "weno": {},
    "weno+cu": {"numerics.flux": "central-upwind"},
    "minmod1.5": {"numerics.reconstruction": "minmod", "numerics.theta": 1.5},
    "minmod2": {"numerics.reconstruction": "minmod", "numerics.theta": 2.0},
    "weno+up": {"numerics.phi_flux": "upwind"},
    "weno+cu+up": {"numerics.flux": "central-upwind", "numerics.phi_flux": "upwind"},
    "minmod2+up": {
        "numerics.reconstruction": "minmod",
        "numerics.theta": 2.0,
        "numerics.phi_flux": "upwind",
    },
}
COLUMNS = (
    "scheme",
    "resolution",
    "phi_centre",
    "phi_error",
    "phi_levee_max",
    "u_centre",
    "u_exact_centre",
    "u_error",
    "steps",
    "rhs_evals",
    "cells",
    "wall_s",
)


def run_one(label: str, res: int, t_end: float) -> dict:
    from tiseg.setup.scene import load_scene
    from tiseg.run.simulation import Simulation
    from tiseg.post.problems.steady_channel import channel_profile
    from tiseg.apps.bench.accuracy import _channel_cells

    sc = load_scene(
        "channel",
        {"domain.resolution": res, "time.t_end": t_end, "output.interval": t_end, **SCHEMES[label]},
    )
    sim = Simulation(sc)
    t0 = time.perf_counter()
    sim.advance(t_end)
    wall = time.perf_counter() - t0
    f = sim.fields()
    phi, u = f["phi"][:, 0], f["u"][:, 0]
    y, frac = _channel_cells(sc)
    ini = sc.initial
    phi_exact = ini.phi_levee + (ini.phi_channel - ini.phi_levee) * frac
    centre = np.abs(y - 0.5 * sc.domain.Ly) < sc.dy
    u_exact = channel_profile(sc).cell_averages(y, sc.dy)
    return {
        "scheme": label,
        "resolution": res,
        "phi_centre": float(phi[centre].mean()),
        "phi_error": float(np.mean(np.abs(phi - phi_exact))),
        "phi_levee_max": float(phi[frac == 0].max()),
        "u_centre": float(u[centre].mean()),
        "u_exact_centre": float(u_exact[centre].mean()),
        "u_error": float(np.sum(np.abs(u - u_exact)) / np.sum(np.abs(u_exact))),
        "steps": sim.stats.steps,
        "rhs_evals": sim.stats.stages,
        "cells": sc.domain.nx * sc.domain.ny,
        "wall_s": wall,
    }


def table(rows: list[dict], key: str, fmt: str) -> list[str]:
    res = sorted({int(r["resolution"]) for r in rows})
    out = ["| scheme | " + " | ".join(f"{r} /m" for r in res) + " |", "|---" * (len(res) + 1) + "|"]
    for label in SCHEMES:
        vals = {int(r["resolution"]): float(r[key]) for r in rows if r["scheme"] == label}
        if vals:
            out.append(
                f"| {label} | "
                + " | ".join(format(vals[r], fmt) if r in vals else "–" for r in res)
                + " |"
            )
    return out


def plot(rows: list[dict], path: Path) -> None:
    """Work-precision diagram: the u(y) error and 1 - phi at the centre against the work."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for label in SCHEMES:
        pts = sorted((r for r in rows if r["scheme"] == label), key=lambda r: int(r["resolution"]))
        if not pts:
            continue
        work = [int(r["rhs_evals"]) * int(r["cells"]) for r in pts]
        style = "-" if label.endswith("+up") else "--"
        axes[0].plot(work, [float(r["u_error"]) for r in pts], style, marker="o", label=label)
        axes[1].plot(
            work,
            [max(1 - float(r["phi_centre"]), 1e-16) for r in pts],
            style,
            marker="o",
            label=label,
        )
        for r, w in zip(pts, work):
            axes[0].annotate(
                str(r["resolution"]),
                (w, float(r["u_error"])),
                fontsize=6,
                xytext=(2, 2),
                textcoords="offset points",
            )
    for ax, ylab in zip(
        axes,
        (
            "relative L1 error of u(y) vs the steady solution",
            "1 - phi at the channel centre (exact: 0)",
        ),
    ):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("work: operator evaluations x cells (labels: cells/m)")
        ax.set_ylabel(ylab)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[1].set_title("upwind phi flux (+up): exact to round-off (1e-16 floor)", fontsize=9)
    fig.suptitle("channel test at t = 3 s: solid = phi_flux upwind, dashed = central", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/contacts")
    ap.add_argument("--resolutions", nargs="+", type=int, default=[250, 375, 500, 750, 1000])
    ap.add_argument("--schemes", nargs="+", default=list(SCHEMES), choices=list(SCHEMES))
    ap.add_argument("--t-end", type=float, default=3.0)
    a = ap.parse_args(argv)
    import tiseg
    from tiseg.apps.bench import machine_info, machine_line

    tiseg.init("cpu", "f64", threads=1)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "contacts.csv"
    rows = []
    if path.exists():
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
    done = {(r["scheme"], int(r["resolution"])) for r in rows}
    for label in a.schemes:
        for res in a.resolutions:
            if (label, res) in done:
                continue
            r = run_one(label, res, a.t_end)
            rows.append(r)
            new = not path.exists()
            with open(path, "a", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=COLUMNS)
                if new:
                    w.writeheader()
                w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
            print(
                f"{label:12s} {res:5d}/m  phi_c {r['phi_centre']:.4f}  u err "
                f"{r['u_error']:.4f}  {r['rhs_evals']} evals  {r['wall_s']:.1f} s",
                flush=True,
            )
    md = [
        f"# Channel test, t = {a.t_end:g} s ({machine_line(machine_info(1))}; one run each)",
        "",
        "phi at the channel centre (exact: 1):",
        "",
        *table(rows, "phi_centre", ".3f"),
        "",
        "mean |phi - phi_exact| over the chute:",
        "",
        *table(rows, "phi_error", ".2e"),
        "",
        "relative L1 error of u(y) against the steady cross-slope solution:",
        "",
        *table(rows, "u_error", ".4f"),
        "",
        "operator evaluations x cells (work) / 1e6:",
        "",
    ]
    for r in rows:
        r["work"] = int(r["rhs_evals"]) * int(r["cells"]) / 1e6
    md += table(rows, "work", ".2f")
    (out / "contacts.md").write_text("\n".join(md) + "\n")
    plot(rows, out / "contacts.png")
    print(f"written {path}, {out / 'contacts.md'} and {out / 'contacts.png'}")
    return 0 if all(math.isfinite(float(r["u_error"])) for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
