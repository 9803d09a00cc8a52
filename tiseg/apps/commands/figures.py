"""`tiseg figures SET`: regenerate the paper's figures; SET is a nested sub-command.

* ``stability``: figures 8-11 (linear stability, sections 4-5);
* ``fingers``: figures 12-18 (the finger simulations and the grid / width / viscosity studies
  of sections 6.2-6.3) and the inviscid limit, computed from sweep results that are run first
  where missing.

Each set registers in `FIGURE_SETS` as (help text, handler, its own options or None).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from .common import add_material_options, check_output_folder, material_from_args
from ...errors import InputError
from ...errors import require

# the repository's README media (a source checkout or an editable install only)
ASSETS_DIR = Path(__file__).resolve().parents[3] / "assets" / "figures"


def _assets_dir() -> Path:

    if not (ASSETS_DIR.parents[1] / "pyproject.toml").is_file():
        raise InputError(
            "--assets copies figures into a source checkout's assets/figures; this "
            "tiseg is installed from a wheel: use --out instead"
        )
    ASSETS_DIR.mkdir(parents=True, exist_ok=True)
    return ASSETS_DIR


def _run_stability(args) -> int:
    from ..figures.stability import make_all

    require(20 <= args.dpi <= 600, f"--dpi={args.dpi!r} must lie in [20, 600]")
    m = material_from_args(args)
    m.require_finger_range()  # the figures are about the segregation-mobility model (3.10)
    check_output_folder(Path(args.out))
    paths = make_all(args.out, m, dpi=args.dpi)
    for p in paths:
        print(p)
    if args.assets:
        _assets_dir()
        for p in paths:
            shutil.copy2(p, ASSETS_DIR / p.name)
            print(ASSETS_DIR / p.name)
    return 0


def _fingers_options(q) -> None:
    g = q.add_argument_group("sweeps behind the figures (run where missing)")
    g.add_argument(
        "--runs",
        default=None,
        metavar="DIR",
        help="folder of the study sweeps (DIR/grid-study, DIR/width-study, "
        "DIR/nu-study, DIR/inviscid-study, ...); default runs/sweeps, or runs/sweeps-quick with "
        "--quick",
    )
    g.add_argument(
        "--quick",
        action="store_true",
        help="run missing studies at low resolution (grid 100/150/200, width and "
        "nu at 150 cells/m): minutes instead of hours, trends only",
    )
    g.add_argument(
        "--resolutions",
        type=float,
        nargs="+",
        default=None,
        metavar="R",
        help="resolutions [cells/m] of the grid study (sweep file: 250 375 500 750) and of "
        "the inviscid study (sweep file: 250 375 500)",
    )
    g.add_argument(
        "--width-resolution",
        type=float,
        default=None,
        metavar="R",
        help="resolution of the domain-width study (sweep file: 375)",
    )
    g.add_argument(
        "--nu-resolution",
        type=float,
        default=None,
        metavar="R",
        help="resolution of the viscosity study (sweep file and paper: 500)",
    )
    g.add_argument(
        "--beyond",
        action="store_true",
        help="also the finite release and the monodisperse front (not in the paper's simulations)",
    )
    g.add_argument(
        "--no-run", action="store_true", help="never start a run: draw what the runs folder holds"
    )
    g.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="local Dask worker processes for missing runs (default: CPU cores)",
    )
    g.add_argument(
        "--threads-per-task",
        type=int,
        default=None,
        metavar="N",
        help="Taichi CPU threads per run (default: cores / workers)",
    )
    g.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run missing sweeps on this Dask scheduler instead of a local cluster",
    )


def _run_fingers(args) -> int:
    from ..figures.fingers import FILES, make_all, shrink_copy

    require(20 <= args.dpi <= 600, f"--dpi={args.dpi!r} must lie in [20, 600]")
    settings: dict = {}
    if args.resolutions:
        require(
            all(20 <= r <= 3000 for r in args.resolutions),
            "--resolutions: choose resolutions between 20 and 3000 cells per metre",
        )
        resolutions = {"grid": {"domain.resolution": sorted(set(args.resolutions))}}
        settings["grid"] = settings["inviscid"] = resolutions
    for key, value in (("width", args.width_resolution), ("nu", args.nu_resolution)):
        if value is not None:
            require(
                20 <= value <= 3000,
                f"--{key}-resolution={value!r}: choose between 20 and 3000 cells per metre",
            )
            settings[key] = {"set": {"domain.resolution": value}}
    runs = (
        Path(args.runs)
        if args.runs
        else Path("runs") / ("sweeps-quick" if args.quick else "sweeps")
    )
    check_output_folder(Path(args.out))
    paths = make_all(
        args.out,
        runs,
        dpi=args.dpi,
        quick=args.quick,
        settings=settings,
        beyond=args.beyond,
        run=not args.no_run,
        scheduler=args.scheduler,
        workers=args.workers,
        threads_per_task=args.threads_per_task,
        progress_interval=60.0,
    )
    for p in paths:
        print(p)
    if args.assets:
        pngs = set(FILES.values())
        assets = _assets_dir()
        for p in paths:
            if p.name in pngs:  # small palette copies: commit-worthy (< 150 kB)
                print(shrink_copy(p, assets / p.name))
    return 0


def _run_deposit(args) -> int:
    from ..figures.deposit import deposit_figure

    require(20 <= args.dpi <= 600, f"--dpi={args.dpi!r} must lie in [20, 600]")
    check_output_folder(Path(args.out))
    path = deposit_figure(args.run, args.out, dpi=args.dpi)
    print(path)
    if args.assets:
        dest = _assets_dir() / path.name
        shutil.copy2(path, dest)
        print(dest)
    return 0


def _deposit_options(q) -> None:
    q.add_argument(
        "run",
        metavar="RUN_DIR",
        help="run folder of a finite release (e.g. tiseg run finite-release-deposit)",
    )


FIGURE_SETS = {
    "stability": (
        "figures 8-11: F(h0, phi0), growth rates sigma_M(k), sigma_Max(F) and k_c(F)",
        _run_stability,
        add_material_options,
    ),
    "fingers": (
        "figures 12-18: finger panels, grid/width/viscosity/inviscid studies (from sweeps)",
        _run_fingers,
        _fingers_options,
    ),
    "deposit": (
        "the deposit of a finite release that came to rest, beside figures 3(b), 4(b)",
        _run_deposit,
        _deposit_options,
    ),
}


# `tiseg figures --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    ("tiseg figures stability --out figures", "figures 8-11 (seconds)"),
    ("tiseg figures fingers --out figures --quick", "figures 12-18 from small sweeps (minutes)"),
    (
        "tiseg figures deposit runs/finite-release-deposit --out figures",
        "the deposit of a finished finite release",
    ),
]


def register(sub) -> None:
    p = sub.add_parser(
        "figures",
        help="regenerate figures of the paper as PNG files",
        description="Regenerate the paper's figures. Choose a set of figures.",
    )
    sets = p.add_subparsers(dest="figure_set", metavar="SET")
    sets.required = True
    for name, (text, func, options) in FIGURE_SETS.items():
        q = sets.add_parser(name, help=text, description=text)
        q.add_argument("--out", required=True, metavar="DIR", help="output folder for the PNGs")
        q.add_argument("--dpi", type=int, default=90, help="resolution (default 90)")
        q.add_argument(
            "--assets",
            action="store_true",
            help=f"also copy the PNGs into the repository's {ASSETS_DIR}",
        )
        if options is not None:
            options(q)
        q.set_defaults(func=func)
