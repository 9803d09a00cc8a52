"""Ensembles of M members one at a time against batched, for M = 1, 4, 16, 64 at two grids.

    python benchmarks/sweep_table.py [--members 1 4 16 64] [--resolutions 100 250]
                                     [--workers 2] [--out DIR]

Each ensemble is M inflow seeds of the fingers scene on a 0.3 m wide chute to t = 7.5 s (the
ensemble of benchmarks/sweep_batch.py, at 100 or 250 cells/m), run by ``tiseg sweep`` twice
into fresh folders: with ``--batch 1`` (every member alone, a worker's members on the
kernels it built for its first) and with ``--batch ceil(M / workers)`` (one task per
worker, its members advanced together, `tiseg.run.batch.Batch`). Both use ``--workers``
Dask workers of one Taichi thread. Records the wall
time of each command, the sum of the members' own run times (done.json ``wall_s``: their steps
and output), whether every member's fields.nc is bitwise the same in both, and per grid the
memory of one member: the peak resident size of a process that runs one member alone against
the same process that only imports tiseg, and the memory check's estimate
(`tiseg.run.limits.memory_needed`).

Writes benchmarks/sweep_batch/table.json after every measurement (a measured entry is kept
and skipped on the next call: delete it, or the file, to measure again) and prints the table.
Before each timed sweep a short one (to 0.05 s) compiles its kernels into Taichi's cache,
so both modes are timed warm. Run it on a quiet machine; the ratios of wall times measured in
one call are the numbers to quote, with the machine named.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent / "sweep_batch"
RESULTS = HERE / "table.json"
sys.path.insert(0, str(Path(__file__).resolve().parent))

from sweep_batch import _same  # noqa: E402  (the bitwise comparison of two fields.nc)

ENV = dict(os.environ, TI_SKIP_VERSION_CHECK="ON", ENABLE_TAICHI_HEADER_PRINT="0", MPLBACKEND="Agg")

SWEEP = """name = "seeds-{m}-{r}"
scene = "fingers"

[set]
"domain.resolution" = {r}
"domain.Ly" = 0.3
"time.t_end" = {t_end}

[grid]
"inflow.seed" = {seeds}
"""

# peak resident memory of one member alone, and of the same process before it starts
MEMBER = r"""
import resource, sys, json
from tiseg.run.limits import memory_needed
from tiseg.setup.reading import load_scene
from tiseg.run.simulation import Simulation
import tiseg
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
scene = load_scene("fingers", {"domain.resolution": int(sys.argv[1]), "domain.Ly": 0.3,
                               "time.t_end": 1.0, "output.interval": 0.5})
tiseg.init("cpu", "f64", 1)
sim = Simulation(scene)
sim.run(out_dir=sys.argv[2], progress=False)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
est = memory_needed(sim.op.lay, sim.op.state.nslots, "f64")
print(json.dumps({"base_kib": base, "peak_kib": peak, "estimate_bytes": est,
                  "cells": scene.domain.nx * scene.domain.ny}))
"""


def _sweep(m: int, r: int, batch: int, workers: int, out: Path, t_end: float = 7.5) -> dict:
    spec = out.with_suffix(".toml")
    spec.write_text(SWEEP.format(m=m, r=r, t_end=t_end, seeds=list(range(1, m + 1))))
    return timed_sweep([str(spec)], batch, workers, out)


def timed_sweep(args: list[str], batch: int, workers: int, out: Path) -> dict:
    """``tiseg sweep ARGS --out OUT --batch B --workers W`` (one Taichi thread a task): its
    wall time and the members' own run times (their done.json)."""
    cmd = [sys.executable, "-m", "tiseg.apps.cli", "-q", "sweep", *args, "--out", str(out)]
    cmd += ["--batch", str(batch), "--workers", str(workers), "--threads-per-task", "1"]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, env=ENV)
    wall = time.perf_counter() - t0
    done = [json.loads(p.read_text()) for p in sorted(out.glob("*/done.json"))]
    return {
        "batch": batch,
        "wall_s": round(wall, 2),
        "members_run_s": round(sum(d["wall_s"] for d in done), 2),
        "members": len(done),
    }


def _member_memory(r: int, root: Path) -> dict:
    out = root / f"memory-{r}"
    shutil.rmtree(out, ignore_errors=True)
    got = subprocess.run(
        [sys.executable, "-c", MEMBER, str(r), str(out)],
        check=True,
        env=ENV,
        capture_output=True,
        text=True,
    )
    m = json.loads(got.stdout.strip().splitlines()[-1])
    return {
        "cells": m["cells"],
        "process_before_mib": round(m["base_kib"] / 1024, 1),
        "process_peak_mib": round(m["peak_kib"] / 1024, 1),
        "member_mib": round((m["peak_kib"] - m["base_kib"]) / 1024, 1),
        "estimate_mib": round(m["estimate_bytes"] / 1024**2, 1),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--members", type=int, nargs="+", default=[1, 4, 16, 64])
    ap.add_argument("--resolutions", type=int, nargs="+", default=[100, 250])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=None, help="where the sweeps go (default: a temporary folder)")
    args = ap.parse_args(argv)
    res = json.loads(RESULTS.read_text()) if RESULTS.is_file() else {}
    res.setdefault("runs", {})
    res.setdefault("memory", {})
    res["machine"] = f"{platform.machine()}, {os.cpu_count()} cores ({platform.node()})"
    res["workers"] = args.workers
    res["batched_mode"] = "together: one launch a stage for all members of a task"
    root = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="sweep-table-"))

    def save():
        RESULTS.write_text(json.dumps(res, indent=1) + "\n")

    for r in args.resolutions:
        if str(r) not in res["memory"]:
            res["memory"][str(r)] = _member_memory(r, root)
            save()
        for m in args.members:
            key = f"{r}/{m}"
            if key in res["runs"]:
                continue
            batched = max(1, math.ceil(m / args.workers))
            entry = {}
            folders = {}
            for mode, b in (("one_at_a_time", 1), ("batched", batched)):
                # the kernels of this grid and batch size compiled into Taichi's cache first
                # (a short sweep, not timed): a batch of M members compiles its own kernels
                # once, as a new grid does, and both modes are then timed warm
                warm = root / f"r{r}-m{m}-{mode}-warm"
                _sweep(m, r, b, args.workers, warm, t_end=0.05)
                shutil.rmtree(warm, ignore_errors=True)
                out = root / f"r{r}-m{m}-{mode}"
                shutil.rmtree(out, ignore_errors=True)
                entry[mode] = _sweep(m, r, b, args.workers, out)
                folders[mode] = out
            names = sorted({p.parent.name for p in folders["batched"].glob("*/fields.nc")})
            entry["bitwise_equal"] = all(
                _same(
                    folders["one_at_a_time"] / n / "fields.nc", folders["batched"] / n / "fields.nc"
                )
                for n in names
            )
            entry["ratio"] = round(entry["batched"]["wall_s"] / entry["one_at_a_time"]["wall_s"], 3)
            res["runs"][key] = entry
            save()
            for f in folders.values():  # the 64-member sweeps at 250 cells/m take gigabytes
                shutil.rmtree(f, ignore_errors=True)
    print(f"{res['machine']}, {args.workers} workers of one thread")
    print(
        "| cells/m | M | one at a time [s] | batched [s] (--batch) | ratio | members' own run time, "
        "one at a time / batched [s] | bitwise |"
    )
    print("|---|---|---|---|---|---|---|")
    for key, e in sorted(res["runs"].items(), key=lambda kv: tuple(map(int, kv[0].split("/")))):
        r, m = key.split("/")
        a, b = e["one_at_a_time"], e["batched"]
        print(
            f"| {r} | {m} | {a['wall_s']:.1f} | {b['wall_s']:.1f} ({b['batch']}) | {e['ratio']:.2f} "
            f"| {a['members_run_s']:.1f} / {b['members_run_s']:.1f} | {e['bitwise_equal']} |"
        )
    print("| cells/m | cells | one member's peak memory [MiB] | memory check's estimate [MiB] |")
    print("|---|---|---|---|")
    for r, mm in sorted(res["memory"].items(), key=lambda kv: int(kv[0])):
        print(f"| {r} | {mm['cells']} | {mm['member_mib']} | {mm['estimate_mib']} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
