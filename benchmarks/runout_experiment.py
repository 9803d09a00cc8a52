"""A finite release on a chute that bends into a horizontal run-out pad, against what the
laboratory literature reports: docs/validation.md, "A release on a chute with a run-out".

    python benchmarks/runout_experiment.py [--out benchmarks/runout_experiment]
                                           [--slopes 27 30 40 50 60] [--res 250 500]

What could be quoted. No measured front, rear or deposit positions of a finite release on a
chute with a run-out could be read from the sources available while this was written: the
classic experiments (Savage & Hutter 1991, Acta Mech. 86; Hutter, Koch, Pluss & Savage 1995,
Acta Mech. 109; Koch, Greve & Hutter 1994, Proc. R. Soc. A 445; Gray, Wieland & Hutter 1999,
Proc. R. Soc. A 455) give their numbers in the papers' figures and tables, and only their
abstracts were at hand. `PUBLISHED` therefore holds what the abstracts state, each with its
source, and no number that was not read there. The one quantitative statement is about the
apparent friction (Heim's ratio, the drop over the horizontal travel) of laboratory
landslides on a slope that meets a horizontal plane (Wu, Duan, Peng & Zhang 2024, Granular
Matter 26, abstract): their runout decreases linearly as the slope steepens, and their
apparent friction is almost the effective (basal) one at low slope angles, the excess being
put down to the energy lost where the mass meets the plane. Measured positions, once transcribed
from a paper's table or figure, go into `MEASURED` (empty now) and are then printed beside
tiseg's.

The set-up (the choices are ours, not an experiment's): a parabolic cap of grains, 4 mm
thick and 10 cm long, released at rest on a chute inclined at zeta1 (one row per slope) that
levels out into a horizontal pad over a constant-curvature bend of 0.1 m of arc (the model takes
h kappa <= 0.1, a bend of 0.042 m at 60 degrees; 0.1 m keeps h kappa at 0.04 or less), Coulomb friction mu = tan 25 degrees on the
bed, monodisperse, no segregation, no viscosity, 1D along the centreline (a chute with side
walls), the split sweeps (hancock, projected friction). The release's centre lies 0.5 m above
the pad on every slope, so the rows differ only in the slope angle. tiseg's pressure is
hydrostatic (earth-pressure coefficient K = 1), where Savage-Hutter models take an active or
passive K from the internal friction angle; the point mass of tiseg.model.exact_runout, with
and without the curvature term kappa u^2, is printed beside each row.

Each row: the deposit's front, rear and centre of mass along the bed (arc length) and past
the bend's end; the horizontal distance the centre of mass travelled; Heim's ratio tan(alpha) of the centre of mass (its drop over its horizontal
travel) and of the front (from the release's top to the deposit's tip, the Fahrboschung);
the time every cell came to rest; the largest thickness reached on the way (sampled every
0.05 s: above the release's 4 mm where the rear runs into the slowing front, the pile-up the
Scientific Reports abstract describes at steep slopes); mass and wall time. Resumable: rows already in
results.csv are kept and not run again. Writes results.csv and results.md into --out.
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import numpy as np

MU_DEG = 25.0  # bed friction angle delta: mu = tan(delta)
CAP_H, CAP_HALF = 0.004, 0.05  # the release: a parabolic cap 4 mm thick, 10 cm long [m]
X0 = 0.1  # arc length of the cap's centre (a wall at x = 0) [m]
DROP = 0.5  # height of the cap's centre above the run-out pad [m]
BEND = 0.1  # arc length of the bend [m]
ROOM = 0.6  # pad kept past the bend [m]
EDGE = 0.01  # a deposit's front and rear: where h falls below EDGE * CAP_H
SLOPES = (27.0, 30.0, 40.0, 50.0, 60.0)
RES = (250, 500)  # cells per metre of arc
SPLIT = {"stepper": "hancock", "friction_scheme": "projected", "cfl": 0.9}

# What the sources say that this benchmark can be held against. Each entry quotes the
# source's own words (paraphrased only where marked) and where they were read.
PUBLISHED = (
    {
        "source": "Wu, Duan, Peng & Zhang (2024), Implications of sand grains' mobility and "
        "inundating area to landslides at different slope angles, Granular Matter 26, "
        "doi:10.1007/s10035-023-01387-y",
        "where": "abstract",
        "set-up": "laboratory landslides of sand on a slope meeting a horizontal plane, "
        "several slope angles",
        "states": "the runout decreases linearly with an increase in slope angles; the "
        "coefficients of apparent friction (Heim's ratio) and effective friction are almost "
        "identical at low slope angles; the excess is ascribed to energy dissipated as the "
        "mass meets the plane, a power law of the impact angle",
    },
    {
        "source": "Influence of slope angle on deposit morphology and propagation of "
        "laboratory landslides, Scientific Reports 13, 9452 (2023)",
        "where": "abstract",
        "set-up": "an inclined plane followed by a horizontal plane, low-friction base, "
        "slope angles 30-85 degrees",
        "states": "at high slope angles (60-85 degrees) the rear of the sliding mass impacts "
        "the front during the transition from the slope to the horizontal plane",
    },
    {
        "source": "Savage & Hutter (1991), Acta Mech. 86, 201-223; Hutter, Savage & Nohguchi "
        "(1989), Ann. Glaciol. 13",
        "where": "abstracts",
        "set-up": "plastic particles (and glass beads) released on a chute of an inclined "
        "straight, a curved segment and a horizontal run-out",
        "states": "the measured spread and positions are compared with the theory in the "
        "papers' figures; no value is given in the abstracts",
    },
)

# Measured positions transcribed from a paper's table or figure: {slope_deg: {"front": ...,
# "rear": ..., "source": "..."}} in metres along the bed. Empty: none could be read (above).
MEASURED: dict[float, dict] = {}

FIELDS = (
    "slope_deg",
    "cells_per_m",
    "nx",
    "front_s",
    "rear_s",
    "centre_s",
    "front_past_bend",
    "rear_past_bend",
    "centre_past_bend",
    "travel_centre",
    "tan_alpha_centre",
    "tan_alpha_front",
    "point_mass_s",
    "point_mass_tan_alpha",
    "block_no_curv_s",
    "t_rest",
    "h_peak",
    "mass_change",
    "steps",
    "wall_s",
)


def geometry(slope_deg: float):
    """(x_b, Lx, line): where the bend begins so that the cap's centre lies DROP above the
    pad, the domain's length and the `BedLine`."""
    from tiseg.model.bed_line import BedLine

    z1 = math.radians(slope_deg)
    drop_bend = -float(BedLine(z1, 0.0, 0.0, BEND).coordinates(BEND)[1])
    x_b = X0 + (DROP - drop_bend) / math.sin(z1)
    return x_b, x_b + BEND + ROOM, BedLine(z1, 0.0, x_b, BEND)


def scene(slope_deg: float, cells_per_m: int, t_end: float):
    from tiseg.setup.reading import scene_from_dict

    x_b, Lx, _ = geometry(slope_deg)
    nx = int(round(Lx * cells_per_m))
    return scene_from_dict(
        {
            "material": {"zeta_deg": slope_deg},
            "flow": {"h0": CAP_H, "nu": 0.0, "u0": 0.1},
            "effects": {
                "segregation": False,
                "viscosity": False,
                "friction": "coulomb",
                "coulomb_mu": math.tan(math.radians(MU_DEG)),
            },
            "domain": {"Lx": nx / cells_per_m, "nx": nx, "ny": 1},
            "boundary": {"x_lo": "wall", "x_hi": "outflow", "y_lo": "periodic", "y_hi": "periodic"},
            "initial": {"kind": "cap", "x0": X0, "half_width": CAP_HALF, "h": CAP_H},
            "terrain": {"runout": {"x": x_b, "length": BEND, "zeta_deg": 0.0}},
            "numerics": SPLIT,
            "time": {"t_end": t_end},
            "output": {"interval": t_end, "peak_fields": False},
        },
        name=f"runout-{slope_deg:g}",
    )


def _measures(h: np.ndarray, x: np.ndarray, line):
    """(rear, front, centre) arc lengths of a thickness profile and the centre's (X, Z)."""
    wet = np.nonzero(h > EDGE * CAP_H)[0]
    X, Z = line.coordinates(x)
    m = h.sum()
    return (
        float(x[wet[0]]),
        float(x[wet[-1]]),
        float((h * x).sum() / m),
        (float((h * X).sum() / m), float((h * Z).sum() / m)),
    )


def run_one(slope_deg: float, cells_per_m: int) -> dict:
    """One row: run the release until every cell holding material is at rest."""
    from tiseg.model import exact_runout as er
    from tiseg.run.simulation import Simulation

    mu = math.tan(math.radians(MU_DEG))
    x_b, _, line = geometry(slope_deg)
    block = er.slide(line, mu, s0=X0)
    free = er.slide(line, mu, s0=X0, curvature=False)
    t_max = 3.0 * block.t_stop + 1.0
    sc = scene(slope_deg, cells_per_m, t_max)
    sim = Simulation(sc)
    x = np.asarray(sc.domain.cell_centres()[0], dtype=float).ravel()
    h0 = sim.fields()["h"].ravel().copy()
    rear0, _, _, (Xc0, Zc0) = _measures(h0, x, line)
    Xr0, Zr0 = line.coordinates(rear0 - 0.5 * sc.dx)  # the release's top edge
    wall = time.perf_counter()
    t_rest, t, h_peak = math.nan, 0.0, float(h0.max())
    while t < t_max - 1e-9:
        t = min(t + 0.05, t_max)
        sim.advance(t)
        f = sim.fields()
        h_peak = max(h_peak, float(f["h"].max()))
        if t >= block.t_stop and not np.any(f["u"][f["h"] > 1e-6] != 0.0):
            t_rest = t
            break
    wall = time.perf_counter() - wall
    h = sim.fields()["h"].ravel()
    rear, front, centre, (Xc, Zc) = _measures(h, x, line)
    Xf, Zf = line.coordinates(front + 0.5 * sc.dx)
    end = x_b + BEND
    Xb, Zb = line.coordinates(np.array([X0, block.s_stop]))
    return {
        "slope_deg": slope_deg,
        "cells_per_m": cells_per_m,
        "nx": sc.domain.nx,
        "front_s": front + 0.5 * sc.dx,
        "rear_s": rear - 0.5 * sc.dx,
        "centre_s": centre,
        "front_past_bend": front + 0.5 * sc.dx - end,
        "rear_past_bend": rear - 0.5 * sc.dx - end,
        "centre_past_bend": centre - end,
        "travel_centre": Xc - Xc0,
        "tan_alpha_centre": (Zc0 - Zc) / (Xc - Xc0),
        "tan_alpha_front": float((Zr0 - Zf) / (Xf - Xr0)),
        "point_mass_s": block.s_stop,
        "point_mass_tan_alpha": float((Zb[0] - Zb[1]) / (Xb[1] - Xb[0])),
        "block_no_curv_s": free.s_stop,
        "t_rest": t_rest,
        "h_peak": h_peak,
        "mass_change": float(h.sum() / h0.sum() - 1.0),
        "steps": sim.stats.steps,
        "wall_s": wall,
    }


def _read(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with path.open() as fh:
        return [
            {
                k: (float(v) if k not in ("nx", "cells_per_m", "steps") else int(v))
                for k, v in r.items()
            }
            for r in csv.DictReader(fh)
        ]


def _write(path: Path, rows: list[dict]) -> None:
    rows = sorted(rows, key=lambda r: (r["slope_deg"], r["cells_per_m"]))
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]) for k in FIELDS})


def table(rows: list[dict]) -> str:
    mu = math.tan(math.radians(MU_DEG))
    lines = [
        f"mu = tan {MU_DEG:g} deg = {mu:.4f}; release centre {DROP} m above the pad; bend "
        f"{BEND} m of arc; positions past the bend's end [m]; tan(alpha): Heim's ratio.",
        "",
        "| slope | cells/m | front | rear | centre | point mass (with κu²) | block without κu² "
        "| centre's horizontal travel | tan α centre | tan α point mass | tan α front "
        "| at rest [s] | peak h / 4 mm | measured |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in sorted(rows, key=lambda r: (r["slope_deg"], r["cells_per_m"])):
        _, _, line = geometry(r["slope_deg"])
        end = line.x_b + line.L
        meas = MEASURED.get(r["slope_deg"])
        lines.append(
            f"| {r['slope_deg']:g}° | {r['cells_per_m']} | {r['front_past_bend']:.3f} "
            f"| {r['rear_past_bend']:.3f} | {r['centre_past_bend']:.3f} "
            f"| {r['point_mass_s'] - end:.3f} | {r['block_no_curv_s'] - end:.3f} "
            f"| {r['travel_centre']:.3f} | {r['tan_alpha_centre']:.3f} | {r['point_mass_tan_alpha']:.3f} "
            f"| {r['tan_alpha_front']:.3f} | {r['t_rest']:.2f} | {r['h_peak'] / CAP_H:.2f} "
            f"| {'none found' if meas is None else meas} |"
        )
    lines += ["", "Published (each source's abstract; no measured position could be read):", ""]
    lines += [f"- {p['source']} ({p['where']}): {p['states']}." for p in PUBLISHED]
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(Path(__file__).parent / "runout_experiment"))
    ap.add_argument("--slopes", type=float, nargs="+", default=list(SLOPES))
    ap.add_argument("--res", type=int, nargs="+", default=list(RES))
    args = ap.parse_args(argv)

    import tiseg

    tiseg.init(arch="cpu", precision="f64")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "results.csv"
    rows = _read(path)
    done = {(r["slope_deg"], r["cells_per_m"]) for r in rows}
    for res in args.res:
        for slope in args.slopes:
            if (float(slope), res) in done:
                continue
            row = run_one(float(slope), res)
            print(
                f"{slope:g} deg, {res} cells/m: front {row['front_past_bend']:.4f} m past the "
                f"bend, tan alpha {row['tan_alpha_centre']:.4f}, at rest {row['t_rest']:.2f} s, "
                f"{row['wall_s']:.1f} s",
                flush=True,
            )
            rows.append(row)
            _write(path, rows)
    (out / "results.md").write_text(table(rows))
    print(table(rows))


if __name__ == "__main__":
    main()
