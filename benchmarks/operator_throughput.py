"""Cell-updates per second of the full-physics operator: Taichi (f64, f32) vs the NumPy
reference on the same grid, measured side by side in one run.

    python benchmarks/operator_throughput.py [--nx 1125 --ny 375] [--repeat 10]

Each precision runs in its own process (Taichi's precision is fixed at initialisation).
One "cell update" is one evaluation of the semi-discrete operator for one cell.
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import time


def measure(prec: str, nx: int, ny: int, repeat: int, with_reference: bool) -> dict:
    import numpy as np
    import tiseg
    from tiseg.reference import ReferenceOperator
    from tiseg.simulation import Simulation

    tiseg.init("cpu", prec)
    # the paper's fingers physics (WENO, viscosity, segregation, mobility feedback) on a
    # fully wet, noisy uniform flow so that every cell does all the work
    sim = Simulation.from_scene("uniform-flow", {
        "domain.nx": nx, "domain.ny": ny, "domain.Ly": 0.5, "domain.Lx": None,
        "initial.k": 2 * np.pi * 0.002 / (nx / 750), "initial.mode": "noise",
        "initial.amplitude": 0.01, "numerics.reconstruction": "weno", "numerics.precision": prec})
    op = sim.op
    op.rhs(0, 1, 0.0)                      # compile
    t0 = time.perf_counter()
    for _ in range(repeat):
        op.rhs(0, 1, 0.0)
    op.q.to_numpy()                        # wait for the device
    t_ti = (time.perf_counter() - t0) / repeat
    out = {"precision": prec, "taichi_s": t_ti, "taichi_cells_per_s": nx * ny / t_ti}
    if with_reference:
        ref = ReferenceOperator(sim.cfg)
        q = op.get(0)
        t0 = time.perf_counter()
        ref.rhs(q.copy(), 0.0)
        t_np = time.perf_counter() - t0
        out.update(numpy_s=t_np, numpy_cells_per_s=nx * ny / t_np, speedup=t_np / t_ti)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nx", type=int, default=1125)
    ap.add_argument("--ny", type=int, default=375)
    ap.add_argument("--repeat", type=int, default=10)
    ap.add_argument("--child", default=None)
    a = ap.parse_args()
    if a.child:
        print(json.dumps(measure(a.child, a.nx, a.ny, a.repeat, with_reference=True)))
        return
    rows = []
    for prec in ("f64", "f32"):
        res = subprocess.run([sys.executable, __file__, "--child", prec, "--nx", str(a.nx),
                              "--ny", str(a.ny), "--repeat", str(a.repeat)],
                             capture_output=True, text=True, check=True)
        rows.append(json.loads(res.stdout.strip().splitlines()[-1]))
    report = {"grid": [a.nx, a.ny], "machine": platform.processor() or platform.machine(),
              "cpus": os.cpu_count(), "results": rows}
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
