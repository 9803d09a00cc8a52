"""`tiseg calibrate SCENE`: the parameter values whose run reproduces target numbers."""

from __future__ import annotations

import math
from pathlib import Path

from ...errors import InputError
from ...setup.scene import parse_override
from ..calibration import calibration_from_args, run_calibration
from .common import (
    add_dask_options,
    add_json,
    add_out,
    add_overrides,
    add_overwrite,
    dask_options,
    print_json,
    results_written,
    sigterm_stops,
)


# `tiseg calibrate --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    (
        "tiseg calibrate dam-break --set effects.friction=coulomb "
        "--param effects.coulomb_mu=0.12:0.25 --target deposit.run_out=0.22+-0.0015 --budget 10",
        "the friction coefficient that gives a measured run-out",
    ),
    (
        "tiseg calibrate fingers --set domain.resolution=200 --param flow.nu=0.004:0.025:log "
        "--target wavelength_spectral=0.055+-0.003 --time 7.5 --seeds 3",
        "the viscosity that gives a finger wavelength",
    ),
]


def register(sub) -> None:
    p = sub.add_parser(
        "calibrate",
        help="find the parameter values whose run reproduces target numbers; writes "
        "DIR/calibration.json and DIR/misfit.png",
        description="Search the box of the --param ranges for the values whose run of SCENE "
        "gives the --target numbers: any number 'tiseg fingers --json' reports, per time "
        "(at --time) or in its deposit block (deposit.run_out, ...). The misfit is the RMS of "
        "the residuals over the tolerances (else relative); the search is scipy's bounded "
        "Brent method for one parameter, a Latin hypercube then Nelder-Mead for several. "
        "Each point is a sweep member folder in DIR run on Dask; finished ones are reused, "
        "so a killed calibration resumes. Then the interval of each parameter from the "
        "sensitivity of the targets around the best point and their spread (tolerance, "
        "seeds or residual). Every input is checked before any run.",
    )
    p.add_argument("scene", metavar="SCENE", help="built-in scene name or path to a .toml file")
    p.add_argument(
        "--param",
        dest="params",
        action="append",
        default=[],
        metavar="SECTION.KEY=LO:HI",
        help="a scene key to calibrate and its range LO < HI; append :log to search it "
        "log-uniformly (repeatable)",
    )
    p.add_argument(
        "--target",
        dest="targets",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a number to reproduce, NAME=VALUE or NAME=VALUE+-TOLERANCE, e.g. "
        "deposit.run_out=0.22 or wavelength=0.05+-0.004 (repeatable)",
    )
    p.add_argument(
        "--time",
        type=float,
        default=None,
        metavar="T",
        help="output time of the per-time targets [s] (default: the last output time)",
    )
    add_overrides(p, "override a scene key in every run, e.g. --set domain.nx=200 (repeatable)")
    p.add_argument(
        "--budget",
        type=int,
        default=None,
        metavar="N",
        help="at most N runs for the search (default 12 per parameter); the interval adds 2 "
        "per parameter and --seeds N - 1 more",
    )
    p.add_argument(
        "--seeds",
        type=int,
        default=0,
        metavar="N",
        help="run the best point with N seeds (scenes with inflow.noise) and take the spread "
        "of the targets over them for the interval (default 0: none)",
    )
    p.add_argument(
        "--design-seed",
        type=int,
        default=0,
        metavar="S",
        help="seed of the Latin hypercube that starts a search of several parameters (default 0)",
    )
    add_out(p, "output folder (default: runs/calibrations/<scene name>)")
    add_json(p, "print calibration.json on stdout")
    g = p.add_argument_group("where the runs go (as for tiseg sweep)")
    add_dask_options(g, runs="runs")
    add_overwrite(
        g,
        "write into a DIR that holds a calibration of another scene or other --set "
        "overrides, and replace files in member folders that tiseg did not write",
    )
    p.set_defaults(func=run)


def run(args) -> int:
    if args.time is not None and not (math.isfinite(args.time) and args.time >= 0):
        raise InputError(f"--time={args.time!r}: give a time in seconds >= 0")
    fixed = {}
    for text in args.overrides:
        key, value = parse_override(text)
        fixed[key] = value
    cal = calibration_from_args(
        args.scene,
        args.params,
        args.targets,
        time=args.time,
        fixed=fixed,
        budget=args.budget,
        seeds=args.seeds,
        design_seed=args.design_seed,
    )
    name = Path(args.scene).stem if args.scene.endswith(".toml") else args.scene
    out = Path(args.out) if args.out else Path("runs") / "calibrations" / name
    kept = "its finished members are kept: run the same command again to go on"
    with sigterm_stops("the calibration", kept), results_written(out, kept):
        result = run_calibration(cal, out, **dask_options(args))
    if args.json:
        print_json(result.result)
    # a failed member stopped the search: not a result to take as final (exit 1, as a sweep
    # with failed members); the progress lines above name the members and what to do
    return 0 if result.complete else 1
