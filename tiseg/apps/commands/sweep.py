"""`tiseg sweep SWEEP.toml`: run a parameter sweep on Dask and collect one table.

The sweep file format is described in `tiseg.apps.sweep`; built-in sweeps are in ``tiseg/data/sweeps/``
(``tiseg sweep grid-study``).
"""

from __future__ import annotations

from pathlib import Path

from ...errors import InputError
from ...log import note
from .common import add_dask_options, add_json, add_out, add_overrides, add_overwrite


# `tiseg sweep --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    ("tiseg sweep tiny", "a two-member sweep to try it out (seconds)"),
    (
        "tiseg sweep grid-study --workers 2 --threads-per-task 1",
        "the paper's grid study on two workers",
    ),
    (
        "tiseg sweep gate-probability --json",
        "probability maps of a gate release; the summary as JSON",
    ),
]


def register(sub) -> None:
    p = sub.add_parser(
        "sweep",
        help="run a grid or a sample of scene overrides on Dask; writes DIR/sweep.csv and "
        "DIR/sweep.nc",
        description="Run every combination of a sweep file's [grid] overrides and every point "
        "of its [sample] design (applied to its base scene together with the [set] overrides) "
        "as independent tasks on Dask, each into its own run folder, and collect the finger "
        "metrics, the deposit and the run costs into DIR/sweep.csv, DIR/sweep.json and the "
        "dataset DIR/sweep.nc; a Sobol' sample also gives DIR/sensitivity.csv and "
        "DIR/sensitivity.png, and a [probability] table DIR/probability.nc (per-cell "
        "probabilities of exceeding thresholds of h_max and speed_max, means and quantiles of "
        "h_max and of the arrival time; `tiseg render DIR` draws them). Finished runs (folders with "
        "done.json) are reused and runs cut off continue from their checkpoints, so an "
        "interrupted sweep resumes where it stopped. "
        "Every combination is validated before anything runs.",
    )
    p.add_argument(
        "sweep",
        metavar="SWEEP.toml",
        help="sweep file, or the name of a built-in sweep (grid-study, width-study, "
        "nu-study, inviscid-study, finite-release, monodisperse, tiny, tiny-sample, "
        "gate-probability)",
    )
    add_out(p, "output folder (default: runs/sweeps/<sweep name>)")
    add_overrides(p, "add a fixed override to every run, e.g. --set time.t_end=5 (repeatable)")
    p.add_argument(
        "--grid",
        dest="grid",
        action="append",
        default=[],
        metavar="SECTION.KEY=[V1,V2,...]",
        help="replace (or add) a grid axis, e.g. --grid 'domain.resolution=[250,375]' (repeatable)",
    )
    add_dask_options(p, runs="runs")
    add_overwrite(
        p,
        "write into an --out folder that holds another sweep, replacing its table and "
        "the runs it shares folder names with, and files in run folders that tiseg did not "
        "write",
    )
    p.add_argument(
        "--check",
        action="store_true",
        help="validate the sweep file and list its runs, run nothing",
    )
    p.add_argument(
        "--progress-interval",
        type=float,
        default=30.0,
        metavar="S",
        help="seconds between progress lines of one running run (default 30)",
    )
    add_json(
        p,
        "print a JSON summary (folders, counts, one entry per run) on stdout; "
        "progress goes to stderr as always",
    )
    p.set_defaults(func=run)


def run(args) -> int:
    from ...setup.scene import parse_override
    from ..sweep import load_sweep, read_marker, run_sweep

    extra = dict(parse_override(text) for text in args.overrides)
    grid = {}
    for text in args.grid:
        key, values = parse_override(text)
        if not isinstance(values, list):
            raise InputError(f"--grid {text!r}: give a list of values, e.g. {key}=[1, 2]")
        grid[key] = values
    sweep = load_sweep(args.sweep, extra_overrides=extra, grid_overrides=grid)
    out = Path(args.out) if args.out else Path("runs") / "sweeps" / sweep.name
    if args.check:
        design = ""
        if sweep.sample is not None:
            s = sweep.sample
            design = f" ({s.method} sample of n = {s.n}, seed {s.seed})"
        if sweep.probability is not None:
            pr = sweep.probability
            parts = [
                f"{name} > {', '.join(f'{t:g}' for t in ts)} {unit}"
                for name, ts, unit in (
                    ("h_max", pr.h_thresholds, "m"),
                    ("speed_max", pr.speed_thresholds, "m/s"),
                )
                if ts
            ]
            design += f", probability maps of {' and '.join(parts)}"
        print(
            f"sweep {sweep.name!r}: base scene {sweep.scene}, {len(sweep.runs)} runs{design}, valid"
        )
        for r in sweep.runs:
            done = read_marker(out / r.name, r.scene) is not None
            drawn = ""
            if sweep.sample is not None:
                drawn = ", " + ", ".join(f"{k} = {r.values[k]:.4g}" for k in sweep.sample.keys)
            print(
                f"  {r.name}: {r.scene.domain.nx} x {r.scene.domain.ny} cells, t_end "
                f"{r.scene.t_end:g} s{drawn}{' (finished)' if done else ''}"
            )
        return 0

    from .common import dask_options, results_written, sigterm_stops

    kept = "its finished runs are kept: run the same command again to go on"
    with sigterm_stops(f"sweep {sweep.name!r}", kept), results_written(out, kept):
        result = run_sweep(
            sweep,
            out,
            progress_interval=args.progress_interval,
            **dask_options(args),
        )
    if args.json:
        from .common import print_json

        print_json(result.as_dict())
    if result.count("busy"):
        note(
            f"{result.count('busy')} run(s) were skipped because another process runs them; "
            "the sweep is not complete: run it again later"
        )
    return 1 if result.count("failed") or result.count("busy") else 0
