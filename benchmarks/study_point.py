"""A five-seed study point one at a time against batched (issue 51's second target).

    python benchmarks/study_point.py [--resolution 375] [--workers 2] [--out DIR]

The point is the built-in grid study's at one resolution (tiseg/data/sweeps/grid-study.toml
at domain.resolution = R: the fingers scene on the paper's chute, inflow seeds 1 to 5, to
7.5 s), run by ``tiseg sweep`` twice into fresh folders: with ``--batch 1`` (each
seed a task of its own) and with ``--batch ceil(5 / workers)`` (one task a worker, its seeds
advanced together). Both modes are timed warm (a short sweep of each first compiles its
kernels into Taichi's cache). Records the wall times, their ratio, and whether every member's
fields.nc is bitwise the same in both modes, in benchmarks/sweep_batch/study_point.json: each
call adds one measurement of both modes (this VM's timings vary by 10 % between calls: quote
them all).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from sweep_batch import _same  # noqa: E402  (the bitwise comparison of two fields.nc)
from sweep_table import HERE, timed_sweep  # noqa: E402

RESULTS = HERE / "study_point.json"
SEEDS = 5

# the grid study's point (tiseg/data/sweeps/grid-study.toml) at one resolution, to t_end
POINT = """name = "study-point-{r}"
scene = "fingers"
times = {times}

[set]
"domain.resolution" = {r}
"time.t_end" = {t_end}
"output.times" = {out_times}
"output.interval" = 0.25
"inflow.noise" = 1e-4

[grid]
"inflow.seed" = [1, 2, 3, 4, 5]
"""


def _point(root: Path, name: str, r: int, t_end: float) -> list[str]:
    """The sweep file of the point (to ``t_end``: 7.5 s, or a short one that compiles)."""
    out_times = [t for t in (1.9, 2.5, 3.3, 5.0, 5.1, 6.2, 7.5) if t <= t_end]
    times = [t for t in (2.5, 5.0, 7.5) if t <= t_end] or [t_end]
    path = root / f"{name}.toml"
    path.write_text(POINT.format(r=r, t_end=t_end, times=times, out_times=out_times))
    return [str(path)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--resolution", type=int, default=375)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=None, help="where the sweeps go (default: a temporary folder)")
    args = ap.parse_args(argv)
    res = json.loads(RESULTS.read_text()) if RESULTS.is_file() else {}
    key = f"{args.resolution}/{args.workers}"
    root = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="study-point-"))
    # one more measurement of both modes (the machine's noise: quote every one)
    root.mkdir(parents=True, exist_ok=True)
    point = _point(root, "point", args.resolution, 7.5)
    warm_point = _point(root, "warm", args.resolution, 0.05)
    entry = {
        "machine": f"{platform.machine()}, {os.cpu_count()} cores ({platform.node()})",
        "workers": args.workers,
        "members": SEEDS,
        # a lone member runs on its worker's kernels (sweep.members.execute_run's reuse)
        "one_at_a_time_start_up": "once a worker",
    }
    folders = {}
    for mode, b in (("one_at_a_time", 1), ("batched", math.ceil(SEEDS / args.workers))):
        warm = root / f"{mode}-warm"
        timed_sweep(warm_point, b, args.workers, warm)
        shutil.rmtree(warm, ignore_errors=True)
        folders[mode] = out = root / mode
        shutil.rmtree(out, ignore_errors=True)
        entry[mode] = timed_sweep(point, b, args.workers, out)
    names = sorted(p.parent.name for p in folders["batched"].glob("*/fields.nc"))
    entry["bitwise_equal"] = len(names) == SEEDS and all(
        _same(folders["one_at_a_time"] / n / "fields.nc", folders["batched"] / n / "fields.nc")
        for n in names
    )
    entry["ratio"] = round(entry["batched"]["wall_s"] / entry["one_at_a_time"]["wall_s"], 3)
    res.setdefault(key, []).append(entry)
    RESULTS.write_text(json.dumps(res, indent=1) + "\n")
    for f in folders.values():
        shutil.rmtree(f, ignore_errors=True)
    for e in res[key]:
        a, b = e["one_at_a_time"], e["batched"]
        print(
            f"{e['machine']}, {e['workers']} workers of one thread, {SEEDS} seeds at "
            f"{key.split('/')[0]} cells/m: one at a time {a['wall_s']:.1f} s, batched "
            f"(--batch {b['batch']}) {b['wall_s']:.1f} s: ratio {e['ratio']:.2f}, bitwise "
            f"equal: {e['bitwise_equal']}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
