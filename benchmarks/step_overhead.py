"""Kernel launches per step and the per-step overhead of each built-in scene on a tiny grid.

    python benchmarks/step_overhead.py [SCENE ...] [--steps 200] [--threads 1]

On a grid of a few hundred cells a step's arithmetic is negligible: its wall time is the
launches (each Taichi kernel call: argument packing in Python, then the launch) and the host
work around them (the step plan, the callbacks). For each scene (default: every built-in one)
this runs 20 warm-up steps, then counts the kernel calls of ``--steps`` steps by name and
times them (no output folder: the run's own work only), and prints launches per step, wall
per step and what a launch costs on average. The numbers to quote are ratios measured in one
run, with the machine named; writes benchmarks/step_overhead/results.json.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import platform
import sys
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent / "step_overhead" / "results.json"
# a tiny grid: 0.3 m x 0.1 m at 50 cells/m (15 x 5 cells) where the scene takes it, else 30
# cells along x, else the scene's own grid
TINY = {"domain.resolution": 50, "domain.Lx": 0.3, "domain.Ly": 0.1}


def measure(name: str, steps: int) -> dict:
    import taichi.lang.kernel_impl as ki

    from tiseg.run.simulation import Simulation
    from tiseg.setup.reading import load_scene
    from tiseg.errors import InputError

    scene = None
    for grid in (TINY, {"domain.nx": 30}, {}):  # a scene that refuses the tiny grid: its own
        try:
            scene = load_scene(name, {**grid, "time.t_end": 1e4, "output.interval": 1e3})
            break
        except InputError:
            continue
    if scene is None:
        raise SystemExit(f"{name}: no grid this benchmark can set")
    sim = Simulation(scene)
    for _ in range(20):
        sim.step()
    counts: collections.Counter = collections.Counter()
    call = ki.Kernel.__call__

    def counting(self, *args, **kwargs):
        counts[self.func.__qualname__] += 1
        return call(self, *args, **kwargs)

    ki.Kernel.__call__ = counting
    try:
        t0 = time.perf_counter()
        for _ in range(steps):
            sim.step()
        wall = time.perf_counter() - t0
    finally:
        ki.Kernel.__call__ = call
    launches = sum(counts.values()) / steps
    return {
        "scene": name,
        "cells": scene.domain.nx * scene.domain.ny,
        "stepper": scene.numerics.stepper,
        "launches_per_step": round(launches, 2),
        "ms_per_step": round(1e3 * wall / steps, 3),
        "kernels": {k: round(v / steps, 2) for k, v in counts.most_common()},
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args(argv)
    from tiseg import backend
    from tiseg.data import SCENE_DIR, builtin_names

    backend.init("cpu", "f64", args.threads)
    names = args.scenes or builtin_names(SCENE_DIR)
    rows = [measure(n, args.steps) for n in names]
    machine = f"{platform.machine()}, {os.cpu_count()} cores, {args.threads} Taichi thread(s)"
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps({"machine": machine, "rows": rows}, indent=1) + "\n")
    print(f"{machine}; {args.steps} steps each")
    print("| scene | stepper | cells | launches per step | ms per step | ms per launch |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        per = r["ms_per_step"] / max(r["launches_per_step"], 1e-9)
        print(
            f"| {r['scene']} | {r['stepper']} | {r['cells']} | {r['launches_per_step']:.1f} | "
            f"{r['ms_per_step']:.2f} | {per:.3f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
