"""Quick start: simulate the paper's finger set-up (section 6.2) from Python.

    python examples/quickstart.py [--resolution 100] [--t-end 2.0] [--out runs/quickstart]

Loads the built-in `fingers` scene (h0 = 2 mm, phi0 = 0.8, nu = 0.01, inflow (6.8)-(6.9)),
coarsens it, runs it, and prints the conservation budget: the mass in the chute equals the mass
that came through the inflow.
"""

import argparse

import tiseg
from tiseg.run.simulation import Simulation


GALLERY = ["--resolution", "80", "--t-end", "2.0", "--out", "{out}"]  # the docs gallery run


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=float, default=100.0, help="cells per metre")
    ap.add_argument("--t-end", type=float, default=2.0, help="end time [s]")
    ap.add_argument("--out", default="runs/quickstart")
    a = ap.parse_args(argv)

    tiseg.init(arch="cpu", precision="f64")
    sim = Simulation.from_scene(
        "fingers",
        {
            "domain.resolution": a.resolution,
            "time.t_end": a.t_end,
            "output.times": [],
            "output.interval": a.t_end / 4,
        },
    )
    stats = sim.run(out_dir=a.out, progress=False)
    tot, bud = sim.totals(), sim.budget()
    print(
        f"t = {sim.t:.2f} s: {stats.steps} steps, {stats.stages} operator evaluations, "
        f"{stats.wall:.1f} s wall"
    )
    print(
        f"mass in chute {tot['mass']:.6e} m^3, entered through the inflow {bud['mass_in']:.6e} m^3"
    )
    f = sim.fields()
    wet = f["h"] >= sim.scene.numerics.h_min
    print(
        f"front at x = {sim.scene.domain.cell_centres()[0][wet.any(axis=0)].max():.3f} m; "
        f"min phi in the flow {f['phi'][wet].min():.3f} (coarse-rich front)"
    )
    return sim


if __name__ == "__main__":
    main()
