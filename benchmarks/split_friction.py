"""Unsplit (RKC, the scene's stepper) against the split MUSCL-Hancock sweeps on a scene with
friction and segregation, side by side in one process.

    python benchmarks/split_friction.py [--scene finite-release-deposit] [--resolution 100]
        [--t-end 5] [--repeat 2] [--threads 1]

Both runs have the viscosity off (the split sweeps take none); everything else is the
scene's: the extended friction law as the projection, segregation with mobility feedback, the
inflow that stops at 3 s. The runs alternate (unsplit, split, unsplit, ...), so a change of
the machine's load falls on both. A third run, unsplit at half the resolution, gives the
scale of the discretisation error the distance between the two answers is measured against.

Prints one row per run (wall time, steps, operator evaluations or sweeps, cell updates per
second) and the answers: the front (the furthest cell where the thickness averaged across the
slope is 0.5 mm), the largest thickness, whether the material is at rest at the end, the
masses, and the L1 distance of the downslope profiles of the thickness averaged across the
slope. (Without viscosity the release does not stop within the scene's 1.5 m, and after
about 5 s fast channels run ahead, differently for every change of the scheme or the grid:
the default end time compares the flow before that.)
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def _run(scene_name, resolution, t_end, stepper):
    from tiseg.setup.scene import load_scene
    from tiseg.run.simulation import Simulation

    over = {
        "domain.resolution": resolution,
        "effects.viscosity": False,
        "time.t_end": t_end,
        "output.times": [],
    }
    if stepper == "hancock":
        over.update({"numerics.stepper": "hancock", "numerics.step_rule": "max"})
    sim = Simulation(load_scene(scene_name, over))
    for _ in range(3):  # compiles the kernels (not timed): both sweep orders of the split
        sim.step()
    w0 = time.perf_counter()
    steps0, stages0 = sim.stats.steps, sim.stats.stages
    sim.advance(t_end)
    wall = time.perf_counter() - w0
    f = sim.fields()
    x, _ = sim.scene.domain.cell_centres()
    front = f["h"].mean(axis=0) >= 5e-4  # the front: 0.5 mm of thickness averaged across
    cells = sim.layout.nx * sim.layout.ny
    stages = sim.stats.stages - stages0
    return {
        "stepper": stepper,
        "resolution": resolution,
        "wall": wall,
        "steps": sim.stats.steps - steps0,
        "stages": stages,
        "updates_per_s": cells * stages / wall,
        "run_out": float(x[front].max()) if front.any() else float("nan"),
        "h_max": float(f["h"].max()),
        "at_rest": bool(np.all(f["u"] == 0) and np.all(f["v"] == 0)),
        "mass": sim.totals()["mass"],
        "small": sim.totals()["small_mass"],
        "h": f["h"],
        "dx": sim.scene.dx,
        "dy": sim.scene.dy,
    }


def _l1(a, b, coarse=False):
    """Relative L1 distance of two downslope profiles of the thickness averaged across the
    slope (which the phase of fingers, set by round-off, does not move); b averaged 2 by 2
    onto a's cells if coarse."""
    pa, pb = a["h"].mean(axis=0), b["h"].mean(axis=0)
    if coarse:
        n = min(len(pa), len(pb) // 2)
        pa, pb = pa[:n], pb[: 2 * n].reshape(n, 2).mean(axis=1)
    return float(np.abs(pa - pb).sum() / np.abs(pb).sum())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="finite-release-deposit")
    ap.add_argument("--resolution", type=float, default=100.0)
    ap.add_argument("--t-end", type=float, default=5.0)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()
    import tiseg

    tiseg.init(arch="cpu", precision="f64", threads=a.threads)
    runs = []
    for _ in range(a.repeat):
        for st in ("rkc", "hancock"):
            runs.append(_run(a.scene, a.resolution, a.t_end, st))
    coarse = _run(a.scene, a.resolution / 2, a.t_end, "rkc")
    print(f"{a.scene}, {a.resolution:g} cells/m, to {a.t_end:g} s, {a.threads} thread(s)")
    print(
        "| stepper | wall [s] | steps | evaluations or sweeps | cell updates/s | run-out [m]"
        " | h_max [mm] | at rest |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for r in runs + [coarse]:
        print(
            f"| {r['stepper']} ({r['resolution']:g}/m) | {r['wall']:.1f} | {r['steps']} | "
            f"{r['stages']} | {r['updates_per_s']:.3g} | {r['run_out']:.4f} | "
            f"{1e3 * r['h_max']:.3f} | {r['at_rest']} |"
        )
    u = [r for r in runs if r["stepper"] == "rkc"]
    s = [r for r in runs if r["stepper"] == "hancock"]
    wu, ws = min(r["wall"] for r in u), min(r["wall"] for r in s)
    print(f"\nbest wall: unsplit {wu:.1f} s, split {ws:.1f} s: split/unsplit = {ws / wu:.2f}")
    print(f"L1(mean h) split vs unsplit: {_l1(s[0], u[0]):.3g}")
    print(f"L1(mean h) unsplit at half resolution vs unsplit: {_l1(coarse, u[0], True):.3g}")
    print(
        f"front difference: {s[0]['run_out'] - u[0]['run_out']:+.4f} m "
        f"(half resolution: {coarse['run_out'] - u[0]['run_out']:+.4f} m; dx = {u[0]['dx']:.4f})"
    )
    print(
        f"mass: unsplit {u[0]['mass']:.6e}, split {s[0]['mass']:.6e}, "
        f"half resolution {coarse['mass']:.6e}; small: unsplit {u[0]['small']:.6e}, "
        f"split {s[0]['small']:.6e}"
    )


if __name__ == "__main__":
    main()
