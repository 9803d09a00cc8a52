"""Pinned final fields: every built-in scene, small, under every stepper that takes it, in both
precisions and on 1 and 2 threads. A refactor must leave them bitwise the same.

    python benchmarks/pinned_fields.py write DIR      # the fields of this checkout, into DIR
    python benchmarks/pinned_fields.py compare A B    # every case of A against B, bit for bit

``write --quick`` runs f64 on 1 thread only (a quarter of the time, about 2 minutes on 2 cores);
``compare`` then checks the cases both folders hold.

Each (precision, threads) pair runs in its own process (Taichi is initialised once per
process). A case is a scene on a grid of about 48 cells along x (and its own aspect), with its
inflow, effects and boundaries as they are, advanced by ``STEPS`` steps of the stepper; a
stepper that the scene refuses (an `InputError`) is recorded as refused, and the refusal must be
the same on both sides. The fields are the conserved state of slot 0 (interior and ghosts as
the operator holds them, `Simulation.conserved`), the time, and the mass budget.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

STEPS = 12
CELLS_X = 48
STEPPERS = ("scene", "rkc", "ssprk3", "ssprk2", "euler", "hancock")
RUNS = (("f64", 1), ("f64", 2), ("f32", 1), ("f32", 2))


def _cases():
    from tiseg.data import SCENE_DIR, builtin_names

    return builtin_names(SCENE_DIR)


def _grid(name: str) -> dict:
    """About CELLS_X cells along x: through the scene's own grid keys (nx, ny or resolution)."""
    import tomllib

    from tiseg.data import SCENE_DIR
    from tiseg.setup.scene import load_scene

    domain = tomllib.loads((SCENE_DIR / f"{name}.toml").read_text()).get("domain", {})
    if "nx" in domain:
        grid = {"domain.nx": CELLS_X}
        if "ny" in domain:
            grid["domain.ny"] = max(1, round(domain["ny"] * CELLS_X / domain["nx"]))
        return grid
    return {"domain.resolution": max(1.0, round(CELLS_X / load_scene(name).domain.Lx))}


def _worker(out: Path, precision: str, threads: int) -> None:
    import tiseg
    from tiseg.errors import InputError
    from tiseg.run.simulation import Simulation
    from tiseg.setup.scene import load_scene

    tiseg.init("cpu", precision, threads)
    out.mkdir(parents=True, exist_ok=True)
    summary = {}
    for name in _cases():
        for stepper in STEPPERS:
            key = f"{name}.{stepper}.{precision}.t{threads}"
            sets = {**_grid(name), "output.times": [], "numerics.precision": precision}
            if stepper != "scene":
                sets["numerics.stepper"] = stepper
            try:
                sim = Simulation(load_scene(name, sets), precision=precision, threads=threads)
                for _ in range(STEPS):
                    sim.step()
            except InputError as e:
                summary[key] = f"refused: {e}"
                continue
            np.savez(
                out / f"{key}.npz",
                q=sim.conserved(),
                t=np.array(sim.t),
                budget=np.array(sorted(sim.budget().items()), dtype=object),
            )
            summary[key] = "ran"
    (out / f"summary.{precision}.t{threads}.json").write_text(json.dumps(summary, indent=1))


def write(out: Path, quick: bool = False) -> None:
    procs = [
        subprocess.Popen(
            [sys.executable, __file__, "_worker", str(out), precision, str(threads)],
        )
        for precision, threads in (RUNS[:1] if quick else RUNS)
    ]
    bad = [p.wait() for p in procs]
    if any(bad):
        sys.exit(f"a worker failed: {bad}")


def compare(a: Path, b: Path) -> int:
    differ = []
    n = 0
    for sa in sorted(a.glob("summary.*.json")):
        if not (b / sa.name).exists():
            continue
        left = json.loads(sa.read_text())
        right = json.loads((b / sa.name).read_text())
        for key, what in left.items():
            n += 1
            if right.get(key) != what:
                differ.append(f"{key}: {what!r} vs {right.get(key)!r}")
                continue
            if what != "ran":
                continue
            za = np.load(a / f"{key}.npz", allow_pickle=True)
            zb = np.load(b / f"{key}.npz", allow_pickle=True)
            for f in ("q", "t"):
                if za[f].shape != zb[f].shape or za[f].tobytes() != zb[f].tobytes():
                    differ.append(f"{key}: {f} differs")
            if not np.array_equal(za["budget"], zb["budget"]):
                differ.append(f"{key}: budget differs")
    if not n:
        differ.append("no case in common")
    print(f"{n} cases, {len(differ)} differ")
    for d in differ:
        print("  " + d)
    return 1 if differ else 0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("write")
    w.add_argument("out", type=Path)
    w.add_argument("--quick", action="store_true", help="f64 on 1 thread only")
    c = sub.add_parser("compare")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    k = sub.add_parser("_worker")
    k.add_argument("out", type=Path)
    k.add_argument("precision")
    k.add_argument("threads", type=int)
    args = ap.parse_args()
    if args.cmd == "write":
        write(args.out, args.quick)
    elif args.cmd == "compare":
        sys.exit(compare(args.a, args.b))
    else:
        _worker(args.out, args.precision, args.threads)


if __name__ == "__main__":
    main()
