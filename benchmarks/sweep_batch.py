"""Wall time of a sweep run one member per task against batches of members on shared kernels.

    python benchmarks/sweep_batch.py [--batches 1 8] [--workers 2] [--out DIR]

Runs the sweep benchmarks/sweep_batch/seeds.toml (16 inflow seeds of the fingers scene at
100 cells/m, 0.3 m wide, to 7.5 s) with ``tiseg sweep --batch B`` for each B, each into a
fresh folder, in the order given, and records the command's wall time; then checks that
every member's fields.nc is bitwise the same under every B. Writes
benchmarks/sweep_batch/results.json (a measured B is kept and skipped on the next call:
delete the file to measure again) and prints a table. Run it on a quiet machine: the ratio of
the wall times is the number to quote, with the machine named.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent / "sweep_batch"
SWEEP = HERE / "seeds.toml"
RESULTS = HERE / "results.json"


def _run(batch: int, workers: int, out: Path) -> float:
    env = dict(
        os.environ, TI_SKIP_VERSION_CHECK="ON", ENABLE_TAICHI_HEADER_PRINT="0", MPLBACKEND="Agg"
    )
    cmd = [sys.executable, "-m", "tiseg.apps.cli", "-q", "sweep", str(SWEEP), "--out", str(out)]
    cmd += ["--batch", str(batch), "--workers", str(workers), "--threads-per-task", "1"]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, env=env)
    return time.perf_counter() - t0


def _fields(path: Path) -> dict:
    import netCDF4

    with netCDF4.Dataset(path) as ds:
        return {k: np.array(v[:]) for k, v in ds.variables.items()}


def _same(a: Path, b: Path) -> bool:
    fa, fb = _fields(a), _fields(b)
    return fa.keys() == fb.keys() and all(np.array_equal(fa[k], fb[k], equal_nan=True) for k in fa)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--batches", type=int, nargs="+", default=[1, 8])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=None, help="where the sweeps go (default: a temporary folder)")
    args = ap.parse_args(argv)
    results = json.loads(RESULTS.read_text()) if RESULTS.is_file() else {"runs": {}}
    root = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="sweep-batch-"))
    folders = {}
    for b in args.batches:
        out = root / f"batch{b}"
        folders[b] = out
        if str(b) in results["runs"] and (out / "sweep.csv").is_file():
            continue
        shutil.rmtree(out, ignore_errors=True)
        wall = _run(b, args.workers, out)
        results["runs"][str(b)] = {"batch": b, "workers": args.workers, "wall_s": round(wall, 2)}
        results["machine"] = f"{platform.machine()}, {os.cpu_count()} cores ({platform.node()})"
        RESULTS.write_text(json.dumps(results, indent=1) + "\n")
    first = folders[args.batches[0]]
    members = sorted(p.name for p in first.iterdir() if (p / "fields.nc").is_file())
    for b in args.batches[1:]:
        same = all(_same(first / m / "fields.nc", folders[b] / m / "fields.nc") for m in members)
        results["runs"][str(b)]["bitwise_equal_to_batch_%d" % args.batches[0]] = same
    RESULTS.write_text(json.dumps(results, indent=1) + "\n")
    base = results["runs"][str(args.batches[0])]["wall_s"]
    print(f"{len(members)} members, {args.workers} workers; {results.get('machine', '')}")
    print("| --batch | wall [s] | ratio to --batch %d | fields bitwise equal |" % args.batches[0])
    print("|---|---|---|---|")
    for b in args.batches:
        r = results["runs"][str(b)]
        eq = r.get("bitwise_equal_to_batch_%d" % args.batches[0], "(reference)")
        print(f"| {b} | {r['wall_s']:.1f} | {r['wall_s'] / base:.2f} | {eq} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
