"""`tiseg run SCENE`: simulate a scene and write scene.toml, fields.nc, diagnostics.csv."""
from __future__ import annotations

import math
from pathlib import Path

from .common import print_json


def add_scene_arguments(p) -> None:
    p.add_argument("scene", help="built-in scene name (e.g. fingers) or path to a TOML file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="override a scene value, e.g. --set domain.resolution=250 (repeatable)")
    p.add_argument("--arch", choices=("cpu", "gpu", "auto"), default="cpu",
                   help="Taichi backend: cpu, gpu (CUDA/Metal; error if none) or auto (default cpu)")
    p.add_argument("--precision", choices=("f32", "f64"), default=None,
                   help="floating-point precision (default: the scene's numerics.precision)")
    p.add_argument("--threads", type=int, default=0, help="CPU threads (0 = all cores)")


def register(sub) -> None:
    p = sub.add_parser("run", help="run a scene; writes scene.toml, fields.nc, diagnostics.csv",
                       description="Simulate a scene (built-in name or TOML file) and write the "
                                   "resolved scene, NetCDF snapshots at the output times and a "
                                   "diagnostics table into the output folder.")
    add_scene_arguments(p)
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output folder (default: runs/<scene name>)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print a JSON summary at the end")
    p.set_defaults(func=run)


def load(args):
    from ..scene import load_scene
    overrides = list(args.overrides)
    if args.precision:
        overrides.append(f"numerics.precision={args.precision}")
    return load_scene(args.scene, overrides)


def run(args) -> int:
    from ..errors import InputError
    from ..simulation import Simulation

    if args.threads < 0:
        raise InputError(f"--threads={args.threads}: must be >= 0")
    scene = load(args)
    out = Path(args.out) if args.out else Path("runs") / scene.name
    sim = Simulation(scene, arch=args.arch, threads=args.threads)
    before = sim.totals()
    stats = sim.run(out_dir=out, progress=not args.no_progress)
    after = sim.totals()
    bud = sim.budget()
    summary = {
        "scene": scene.name, "out": str(out), "t_end": sim.t, "steps": stats.steps,
        "rhs_evaluations": stats.stages, "wall_time_s": stats.wall,
        "arch": sim.backend.arch, "precision": sim.backend.precision,
        "grid": [scene.domain.nx, scene.domain.ny],
        "mass": after["mass"], "mass_in": bud["mass_in"],
        "mass_balance_error": after["mass"] - before["mass"] - bud["mass_in"],
        "cell_updates_per_s": scene.domain.nx * scene.domain.ny * stats.stages / max(stats.wall, 1e-12),
    }
    if args.json:
        print_json(summary)
    else:
        print(f"{scene.name}: t = {sim.t:.4g} s in {stats.steps} steps ({stats.stages} operator "
              f"evaluations), wall {stats.wall:.1f} s on {sim.backend.arch}/{sim.backend.precision}; "
              f"{summary['cell_updates_per_s'] / 1e6:.2f} M cell-updates/s")
        rel = summary["mass_balance_error"] / max(abs(after["mass"]), 1e-300)
        print(f"mass balance error {summary['mass_balance_error']:.3g} m^3 (relative {rel:.2g}); "
              f"output in {out}/")
    return 0
